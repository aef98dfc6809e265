"""Settings of the diagnosis: :class:`DiagnosisConfig` (its keys and its fixed settings).

They live in :mod:`microdoppler.causes.config` (the causes' tests read them); this
module re-exports them under the diagnosis' name.
"""

from ..causes.config import *  # noqa: F401,F403 (re-exported)
from ..causes.config import DiagnosisConfig, unknown_key_error  # noqa: F401 (named re-exports)
