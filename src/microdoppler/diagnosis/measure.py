"""Step 1 of the diagnosis: measure a drone flight against the paper's model of it.

The measurement lives in :mod:`microdoppler.causes.measure` (the causes' tests read
it); this module re-exports it under the diagnosis' name.
"""

from ..causes.measure import *  # noqa: F401,F403 (re-exported)
from ..causes.measure import DB, Measurements, Stft, Undiagnosable, measure  # noqa: F401 (named re-exports)
