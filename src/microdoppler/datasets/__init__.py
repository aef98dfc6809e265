"""Datasets of the experiment (paper §III.C, §V.A-B): the flight-disjoint split,
motor speeds per sampling variant, calibrated synthetic twins, background injection,
spectrogram tiles and the training sets.

- ``split``        60:30:10 split by class, never splitting a flight
- ``tables``       Table III (set composition) and Table IV (fitted parameters)
- ``lines``        body and HERM line SNR (the project's one SNR measure, located)
- ``speeds``       motor speeds per sampling variant (stage resample_motor_speeds)
- ``calibration``  synthetic twins and their per-flight fit (stage synthesize_flights)
- ``injection``    twin + recorded background (stage inject_background)
- ``imaging``      the spectrogram settings resolved for the flights' PRF and carrier
- ``tiles``        20-timestep spectrogram images (stage tile_spectrograms)
- ``loader``       ``load_trainset(name, tiles_dir) -> (train, val, test)``
- ``figures``      measured vs twin spectrograms (Fig. 9/10)
"""

from .calibration import CalibrationConfig, fit_twin
from .injection import inject
from .loader import TileSet, load_trainset
from .split import CLASSES, SETS, TWIN_MODELS, split_flights

__all__ = [
    "TileSet",
    "load_trainset",
    "CLASSES",
    "SETS",
    "TWIN_MODELS",
    "split_flights",
    "fit_twin",
    "CalibrationConfig",
    "inject",
]
