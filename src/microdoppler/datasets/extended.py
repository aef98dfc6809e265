"""The ``extended`` variant's model extensions, per twin (``extensions/2``).

They live in :mod:`microdoppler.causes.twins` (the diagnosis writes them); this
module re-exports them under the datasets' name.
"""

from ..causes.twins import *  # noqa: F401,F403 (re-exported)
from ..causes.twins import (
    MODES,
    SCHEMA,
    TwinExtensions,
    catalog_params,  # noqa: F401 (named re-exports)
    fit_population,
    load_twin_extensions,
    save_twin_extensions,
    twin_extensions,
)
