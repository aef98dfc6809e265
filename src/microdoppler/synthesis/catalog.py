"""The catalog of discrepancies between measured flights and the paper's simulation.

This module is the single definition of each cause's *parameters* (names, units,
signs, detectable ranges). The measurement emulator implements the causes with its
own physics (``microdoppler.emulator``); the diagnosis fits model extensions with the
same parameter names (``microdoppler.synthesis.extensions``), so a fitted value can be compared
with the emulator's truth. See ``shared/formats/flight-zarr.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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
            (Param("body_std_db", "dB", "standard deviation of the body power gain in dB", ">= 3"),
             Param("timescale_s", "s", "1/e correlation time of the body power gain (default 0.3 s when "
                   "not given)", "0.05-3 s")),
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
                   "|f| < 100 Hz (flat PSD); multiplies the whole echo incl. clutter by exp(j theta). For "
                   "another spectral shape: the rms of the flat process with the same skirt at 50 Hz",
                   "raises the floor within 100 Hz of the clutter line by >= 6 dB"),
             Param("skirt_dbc_hz", "dBc/Hz", "single-sideband phase-noise density at 50 Hz from the carrier, "
                   "relative to the carrier (any spectral shape; for the flat process "
                   ":func:`flat_skirt_dbc_hz` of rms_rad)", ">= about -75 dBc/Hz")),
        ),
        Cause(
            "blade_imbalance",
            "the blades of a propeller do not scatter alike (a tagged, chipped, bent or differently pitched "
            "blade): lines at multiples of the rotation rate that are not multiples of the blade-passing rate",
            (Param("imbalance_db", "dB", "how far the weakest blade's scattering amplitude lies below the mean of "
                   "the propeller's other blades, 20 log10 of the amplitude ratio, positive", ">= 3"),),
        ),
    ]
}

#: not a model extension: the model, with every named cause's extension, still misses
#: the held-out data by more than noise and the fit's uncertainty allow. Reported last,
#: so that "none" always means that the model fits.
UNEXPLAINED = "unexplained"
CATALOG: tuple[str, ...] = tuple(CAUSES) + (UNEXPLAINED,)
PHASE_NOISE_BANDWIDTH_HZ = 100.0
#: offset from the carrier at which ``skirt_dbc_hz`` is read [Hz]
SKIRT_OFFSET_HZ = 50.0


def flat_skirt_dbc_hz(rms_rad: float, bandwidth_hz: float = PHASE_NOISE_BANDWIDTH_HZ,
                      offset_hz: float = SKIRT_OFFSET_HZ) -> float:
    """``skirt_dbc_hz`` of the catalog's flat phase noise of rms ``rms_rad`` [rad].

    theta(t) Gaussian with a flat two-sided PSD S = rms^2 / (2 B) on |f| < B. The
    spectrum of exp(j theta) relative to its carrier (weight exp(-rms^2)) is
    L(f) = sum_n S_n(f) / n! (S_n: S convolved with itself n times); the first two terms are kept (the third is below
    1e-4 of the first for rms < 0.1 rad): L(f) = S + S^2 (2B - |f|) / 2 [1/Hz].
    Returns 10 log10 L(offset_hz) [dBc/Hz]; -inf for rms 0.
    """
    a = float(rms_rad) ** 2 / (2 * bandwidth_hz)
    lin = a + 0.5 * a * a * max(2 * bandwidth_hz - offset_hz, 0.0)
    return float(10 * np.log10(lin)) if lin > 0 else float("-inf")


def flat_rms_rad(skirt_dbc_hz: float, bandwidth_hz: float = PHASE_NOISE_BANDWIDTH_HZ,
                 offset_hz: float = SKIRT_OFFSET_HZ) -> float:
    """Inverse of :func:`flat_skirt_dbc_hz`: the flat process's rms [rad]."""
    L = 10 ** (float(skirt_dbc_hz) / 10)
    c = max(2 * bandwidth_hz - offset_hz, 0.0)
    a = L if c == 0 else (np.sqrt(1 + 2 * c * L) - 1) / c
    return float(np.sqrt(2 * bandwidth_hz * a))
