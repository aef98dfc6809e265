"""Where the body and HERM lines of a flight are, and their SNR, per timestep.

Every SNR here is :func:`microdoppler.spectra.snr.line_snr_db` (the project's one measure:
the line's peak over the spectrogram's median floor) evaluated at an expected
Doppler:

- the body line at f = -2 v / lambda, v the track's radial velocity [m/s] at each
  timestep's centre;
- the k-th HERM sideband pair at body +/- k B f_rot, f_rot the mean rotor rate of
  the motors [rev/s], B blades per rotor; the search half-width grows with k and
  with the spread of the motors' rates (the four rotors make a cluster of lines),
  capped so that a sideband window never reaches the body or the next harmonic
  (the one reader of the HERM lines, :func:`microdoppler.spectra.lines.herm_line_snr_db`).

A sideband pair's SNR per timestep is the stronger of its two sides (measured
spectra are often asymmetric). Timesteps whose window falls outside the
spectrogram's Doppler span give -inf and are left out of flight statistics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..spectra.lines import herm_line_snr_db
from ..spectra.snr import body_doppler_hz  # noqa: F401 (re-exported)
from ..spectra.spectrogram import Spectrogram


def rotor_rate_at(rev_s: np.ndarray, time_s, prf_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Mean and half-spread over motors of pulse-rate rotor rates at ``time_s``.

    Parameters
    ----------
    rev_s : ndarray, float [n_pulses, n_motors]
        Rotor rates [rev/s] at pulse rate.

    Returns
    -------
    mean_rev_s, half_spread_rev_s : ndarray [n_times]
    """
    idx = np.clip(np.round(np.asarray(time_s) * prf_hz).astype(np.int64), 0, rev_s.shape[0] - 1)
    r = np.asarray(rev_s[idx], dtype=np.float64)
    return r.mean(axis=1), (r.max(axis=1) - r.min(axis=1)) / 2


def log_rate_at(log_time_s, log_rev_s, time_s) -> tuple[np.ndarray, np.ndarray]:
    """As :func:`rotor_rate_at` from a motor log (linear interpolation, held at the ends)."""
    t = np.asarray(time_s, float)
    r = np.column_stack([np.interp(t, log_time_s, log_rev_s[:, m]) for m in range(log_rev_s.shape[1])])
    return r.mean(axis=1), (r.max(axis=1) - r.min(axis=1)) / 2


@dataclass
class LineSNR:
    """Per-timestep SNRs of the body line and the sideband pairs [dB].

    Attributes
    ----------
    body_db : ndarray [n_timesteps]
    upper_db, lower_db : ndarray [n_harmonics, n_timesteps]
        Harmonic k = 1..n_harmonics above and below the body.
    """

    body_db: np.ndarray
    upper_db: np.ndarray
    lower_db: np.ndarray

    @property
    def pair_db(self) -> np.ndarray:
        """Stronger side of each pair: [n_harmonics, n_timesteps]."""
        return np.maximum(self.upper_db, self.lower_db)

    def body_mean_db(self) -> float:
        return finite_mean(self.body_db)

    def sideband_mean_db(self, k: int = 1) -> float:
        return finite_mean(self.pair_db[k - 1])

    def harmonic_medians_db(self, min_valid: float = 0.5) -> np.ndarray:
        """Median over timesteps of each pair's SNR; NaN where fewer than ``min_valid``
        of the timesteps have the pair inside the spectrogram."""
        out = np.full(self.pair_db.shape[0], np.nan)
        n = self.pair_db.shape[1]
        for k, row in enumerate(self.pair_db):
            ok = np.isfinite(row)
            if n and ok.sum() >= min_valid * n:
                out[k] = np.median(row[ok])
        return out

    def n_pairs(self, visible_db: float, min_valid: float = 0.5) -> int:
        """Number of consecutive visible pairs from k = 1 (median SNR >= ``visible_db``)."""
        med = self.harmonic_medians_db(min_valid)
        n = 0
        for m in med:
            if not (np.isfinite(m) and m >= visible_db):
                break
            n += 1
        return n


def finite_mean(x) -> float:
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    return float(np.mean(x)) if x.size else float("nan")


def measure_lines(
    spec: Spectrogram,
    body_hz: np.ndarray,
    rotor_rev_s: np.ndarray | None,
    *,
    n_blades: int = 2,
    rotor_half_spread_rev_s: float = 0.0,
    n_harmonics: int = 6,
    search_hz: float = 10.0,
) -> LineSNR:
    """SNR of the body line and of ``n_harmonics`` sideband pairs, per timestep.

    Parameters
    ----------
    spec : Spectrogram
    body_hz : ndarray [n_timesteps]
        Expected body Doppler [Hz].
    rotor_rev_s : ndarray [n_timesteps] or None
        Mean rotor rate [rev/s]; None (birds, no log) measures the body only.
    rotor_half_spread_rev_s : float
        Half-spread of the motors' rates [rev/s] (a flight-level value).
    search_hz : float
        Search half-width of the body line and base half-width of the sidebands [Hz].
    """
    body_db, up, lo = herm_line_snr_db(
        spec,
        body_hz,
        rotor_rev_s,
        n_blades=n_blades,
        rotor_half_spread_rev_s=rotor_half_spread_rev_s,
        n_harmonics=n_harmonics,
        search_hz=search_hz,
    )
    return LineSNR(body_db, up, lo)
