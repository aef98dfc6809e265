"""The catalog of discrepancies between measured flights and the paper's simulation.

This module is the single definition of each cause's *parameters* (names, units,
signs, detectable ranges). The measurement emulator implements the causes with its
own physics (``microdoppler.emulator``); the diagnosis fits model extensions with the
same parameter names (``microdoppler.extensions``), so a fitted value can be compared
with the emulator's truth. See ``shared/formats/flight-zarr.md``.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Param:
    name: str
    unit: str
    meaning: str
    detectable: str


@dataclass(frozen=True)
class Cause:
    name: str
    meaning: str
    params: tuple[Param, ...]

    @property
    def main_param(self) -> str:
        """The parameter the diagnosis must recover (first one)."""
        return self.params[0].name


CAUSES: dict[str, Cause] = {
    c.name: c
    for c in [
        Cause("none", "the paper's model explains the flight", ()),
        Cause(
            "sideband_asymmetry",
            "HERM sidebands above the body Doppler are stronger (or weaker) than their mirrors below",
            (Param("asymmetry_db", "dB", "10 log10(power of upper sidebands / power of the mirror lower sidebands); "
                   "positive = upper stronger", "|asymmetry_db| >= 3"),),
        ),
        Cause(
            "sideband_fading",
            "blade (sideband) power fluctuates over seconds independently of the body",
            (Param("fading_std_db", "dB", "standard deviation over time of the blade power gain in dB "
                   "(log-normal gain, Ornstein-Uhlenbeck in dB)", ">= 3"),
             Param("timescale_s", "s", "correlation time of the fading", "1-2 s")),
        ),
        Cause(
            "body_fluctuation",
            "the body return's power fluctuates from CPI to CPI (RCS scintillation)",
            (Param("body_std_db", "dB", "standard deviation of the body power gain in dB, "
                   "correlation time ~0.3 s", ">= 3"),),
        ),
        Cause(
            "motor_log_lag",
            "the motor log is shifted in time against the radar",
            (Param("lag_s", "s", "t_logged - t_true: a row stamped t reports the speed at t - lag_s; "
                   "positive = log late", "|lag_s| >= 0.3"),),
        ),
        Cause(
            "motor_speed_scale",
            "the logged speeds are off by a constant factor",
            (Param("scale", "1", "true speed / logged speed (HERM spacing / the log's prediction)",
                   "|scale - 1| >= 0.05"),),
        ),
        Cause(
            "phase_noise",
            "the radar's phase noise spreads strong lines into a raised skirt",
            (Param("rms_rad", "rad", "rms of the radar phase error theta(t), Gaussian, band-limited to "
                   "|f| < 100 Hz (flat PSD); multiplies the whole echo incl. clutter by exp(j theta)",
                   "raises the floor within 100 Hz of the clutter line by >= 6 dB"),),
        ),
    ]
}

CATALOG: tuple[str, ...] = tuple(CAUSES)
PHASE_NOISE_BANDWIDTH_HZ = 100.0
