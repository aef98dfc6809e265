"""Rotor speeds: the paper's sampling variants of logged speeds, and speeds estimated from the radar's HERM lines."""

from .sampling import SamplingConfig, resample
from .speed import RotorEstimate, RotorSpeedConfig, estimate_rotor_speeds

__all__ = ["estimate_rotor_speeds", "RotorSpeedConfig", "RotorEstimate", "resample", "SamplingConfig"]
