"""Where a rotor's lines lie about the body, and what a line of a spectrum reads.

A rotor of ``B`` blades turning at ``f_rot`` [rev/s] modulates the echo periodically:
its lines lie at the body Doppler ``f_b`` plus multiples of the rotation rate, and
identical blades keep only the multiples of ``B``: the HERM lines at
``f_b +- k B f_rot`` (k = 1, 2, ...), a comb of spacing ``B f_rot`` symmetric about the
body. :func:`herm_line_hz` is that placement, for any comb (the HERM lines: spacing
``B f_rot``; every rotation harmonic: spacing ``f_rot``); :func:`herm_windows` lays out
the search window of each HERM pair, and :func:`herm_line_snr_db` reads each line's
SNR with the project's one measure (:func:`microdoppler.spectra.snr.line_snr_db`).
:func:`band_power`, :func:`local_floor`, :func:`band_spans` and :func:`bins_near`
read a line's power on a periodogram grid (an object with ``f_hz``, the centred
Doppler of its bins [Hz], and ``at(f)``, the fractional bin of a Doppler, such as
:class:`microdoppler.causes.measure.Stft`).

Users: the flights' line SNRs (:func:`microdoppler.datasets.lines.measure_lines`), the
calibration's search windows (``datasets.calibration.LineWindows``), the twins'
fidelity features (``datasets.fidelity``) and the diagnosis's per-CPI measurements
(``causes.measure``). The rotor-speed estimator (``rotors.speed``) reads its lines in
bins of its own zero-padded spectra (offsets ``n B f / bin``, interpolated), not in
Hz; expressed through :func:`herm_line_hz` its offsets would round differently in the last
bit, so it keeps its own arithmetic.
"""

from __future__ import annotations

from typing import Iterator

import numpy as np

from .snr import line_snr_db
from .spectrogram import Spectrogram

#: a HERM pair's search half-width is at most this fraction of the line spacing, so a
#: window never reaches the body or the next pair
MAX_HALF_SPACING = 0.45


def herm_line_hz(body_hz, spacing_hz, k, side=1):
    """Doppler [Hz] of line ``k`` of a comb of spacing ``spacing_hz`` about the body:
    ``body_hz + side k spacing_hz``.

    Parameters
    ----------
    body_hz : float or ndarray
        The body's Doppler [Hz] (the comb's centre).
    spacing_hz : float or ndarray
        The comb's spacing [Hz]: ``B f_rot`` for the HERM lines (B blades, rotation
        rate ``f_rot`` [rev/s]), ``f_rot`` for every rotation harmonic.
    k : int or float
        The line's order (1, 2, ...).
    side : int, float or ndarray
        +1 above the body, -1 below.

    Returns
    -------
    float or ndarray
        Broadcast of the arguments [Hz] (evaluated as ``body_hz + side * k * spacing_hz``,
        so every reader places a line to the same bit).

    Examples
    --------
    The HERM lines of a two-bladed rotor at 50 rev/s about a body at 60 Hz:

    >>> from microdoppler.spectra.lines import herm_line_hz
    >>> [float(herm_line_hz(60.0, 2 * 50.0, k, s)) for k in (1, 2) for s in (1, -1)]
    [160.0, -40.0, 260.0, -140.0]
    """
    return body_hz + side * k * spacing_hz


def herm_windows(
    body_hz: np.ndarray,
    rotor_rev_s: np.ndarray,
    *,
    n_blades: int,
    rotor_half_spread_rev_s: float,
    n_harmonics: int,
    search_hz: float,
) -> Iterator[tuple[int, int, np.ndarray, float]]:
    """The search window of every HERM line, pair by pair.

    Parameters
    ----------
    body_hz : ndarray [n_timesteps]
        Expected body Doppler [Hz].
    rotor_rev_s : ndarray [n_timesteps]
        Mean rotor rate [rev/s]; the lines lie at ``body +- k n_blades rotor_rev_s``.
    n_blades : int
        Blades per rotor.
    rotor_half_spread_rev_s : float
        Half-spread of the motors' rates [rev/s]: the rotors' lines of order k form a
        cluster ``k n_blades`` times as wide.
    n_harmonics : int
        Pairs k = 1..n_harmonics.
    search_hz : float
        Base half-width of a window [Hz].

    Yields
    ------
    k : int
        The pair's order.
    side : int
        +1 (above the body) then -1 (below).
    centre_hz : ndarray [n_timesteps]
        The line's expected Doppler (:func:`herm_line_hz`).
    half_hz : float
        The window's half-width: ``search_hz + k n_blades rotor_half_spread_rev_s``,
        at most :data:`MAX_HALF_SPACING` x the median spacing.
    """
    herm = n_blades * np.asarray(rotor_rev_s, float)
    spacing = float(np.median(herm)) if herm.size else 0.0
    for k in range(1, n_harmonics + 1):
        hw = min(search_hz + k * n_blades * rotor_half_spread_rev_s, MAX_HALF_SPACING * spacing)
        for sign in (1, -1):
            yield k, sign, herm_line_hz(body_hz, herm, k, sign), hw


def herm_line_snr_db(
    spec: Spectrogram,
    body_hz: np.ndarray,
    rotor_rev_s: np.ndarray | None,
    *,
    n_blades: int = 2,
    rotor_half_spread_rev_s: float = 0.0,
    n_harmonics: int = 6,
    search_hz: float = 10.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SNR of the body line and of ``n_harmonics`` HERM pairs, per timestep [dB].

    Each line's SNR is :func:`~microdoppler.spectra.snr.line_snr_db` (the peak within
    its window over the timestep's median floor) in the window of
    :func:`herm_windows`; a window that leaves the spectrogram's Doppler span gives
    -inf.

    Parameters
    ----------
    spec : Spectrogram
    body_hz : ndarray [n_timesteps]
        Expected body Doppler [Hz].
    rotor_rev_s : ndarray [n_timesteps] or None
        Mean rotor rate [rev/s]; None (birds, no log) measures the body only.
    n_blades, rotor_half_spread_rev_s, n_harmonics, search_hz
        As :func:`herm_windows` (``search_hz`` is also the body's half-width).

    Returns
    -------
    body_db : ndarray [n_timesteps]
    upper_db, lower_db : ndarray [n_harmonics, n_timesteps]
        Pair k = 1..n_harmonics above and below the body ([0, n_timesteps] without
        ``rotor_rev_s``).

    Examples
    --------
    A two-bladed rotor at 50 rev/s on a body at 60 Hz: lines every 100 Hz about it.

    >>> import numpy as np
    >>> from microdoppler.spectra import spectrogram
    >>> from microdoppler.spectra.lines import herm_line_snr_db
    >>> prf, n = 7300.0, 4 * 4096
    >>> t = np.arange(n) / prf
    >>> blades = sum(np.exp(1j * 2.0 * np.sin(2 * np.pi * 50.0 * t + np.pi * b)) for b in range(2))
    >>> iq = np.exp(2j * np.pi * 60.0 * t) * (1 + blades) + 0.01 * np.random.default_rng(0).standard_normal(n)
    >>> spec = spectrogram(iq.astype(np.complex64), prf)
    >>> body, up, lo = herm_line_snr_db(spec, np.full(7, 60.0), np.full(7, 50.0), n_harmonics=2)
    >>> up.shape, bool(np.all(up > 40) and np.all(lo > 40))
    ((2, 7), True)
    """
    body_db = line_snr_db(spec, body_hz, search_hz=search_hz)
    n_t = len(body_db)
    if rotor_rev_s is None:
        empty = np.full((0, n_t), -np.inf)
        return body_db, empty, empty
    f_lo, f_hi = spec.doppler_hz[0], spec.doppler_hz[-1]
    up = np.full((n_harmonics, n_t), -np.inf)
    lo = np.full((n_harmonics, n_t), -np.inf)
    windows = herm_windows(
        body_hz,
        rotor_rev_s,
        n_blades=n_blades,
        rotor_half_spread_rev_s=rotor_half_spread_rev_s,
        n_harmonics=n_harmonics,
        search_hz=search_hz,
    )
    for k, sign, centre, hw in windows:
        inside = (centre - hw >= f_lo) & (centre + hw <= f_hi)
        s = line_snr_db(spec, centre, search_hz=hw)
        (up if sign > 0 else lo)[k - 1] = np.where(inside, s, -np.inf)
    return body_db, up, lo


# ---- a line's power on a periodogram grid ------------------------------------------------


def band_power(p_row: np.ndarray, st, f_c: float, half_hz: float) -> tuple[float, int]:
    """Sum of the periodogram row ``p_row`` [n_bins] within ``half_hz`` of ``f_c`` [Hz]
    on the grid ``st`` (``f_hz``, ``at``), and the number of bins."""
    lo = int(np.ceil(st.at(f_c - half_hz)))
    hi = int(np.floor(st.at(f_c + half_hz)))
    lo, hi = max(lo, 0), min(hi, len(st.f_hz) - 1)
    if hi < lo:
        return 0.0, 0
    return float(p_row[lo : hi + 1].sum()), hi - lo + 1


def local_floor(p_row: np.ndarray, st, f_c: float, excl_hz: float, span_hz: float) -> float:
    """Mean noise level per bin near ``f_c`` (median / ln 2 of the bins within
    ``span_hz`` but farther than ``excl_hz``; NaN with fewer than 4 such bins)."""
    lo = max(int(np.ceil(st.at(f_c - span_hz))), 0)
    hi = min(int(np.floor(st.at(f_c + span_hz))), len(st.f_hz) - 1)
    if hi <= lo:
        return np.nan
    seg = p_row[lo : hi + 1]
    f = st.f_hz[lo : hi + 1]
    seg = seg[np.abs(f - f_c) > excl_hz]
    if len(seg) < 4:
        return np.nan
    return float(np.median(seg) / np.log(2.0))


def band_spans(st, centres, half) -> tuple[np.ndarray, np.ndarray]:
    """First and last bin (int, clipped to the spectrum; empty where last < first) within
    ``half`` [Hz] of each of ``centres`` [Hz] (pairs of equal index)."""
    n = len(st.f_hz)
    c, w = np.ravel(np.asarray(centres, float)), np.ravel(np.asarray(half, float))
    k = min(len(c), len(w))
    c, w = c[:k], w[:k]
    lo = np.clip(np.ceil(st.at(c - w)), 0, n).astype(int)
    hi = np.clip(np.floor(st.at(c + w)), -1, n - 1).astype(int)
    return lo, hi


def bins_near(st, centres, half) -> np.ndarray:
    """bool [n_bins]: bins within ``half`` [Hz] of any of ``centres`` [Hz] (the pairs
    of equal index; vectorised: the bins of every interval marked at once)."""
    n = len(st.f_hz)
    lo, hi = band_spans(st, centres, half)
    keep = lo <= hi
    edges = np.zeros(n + 1, int)
    np.add.at(edges, lo[keep], 1)
    np.add.at(edges, hi[keep] + 1, -1)
    return np.cumsum(edges[:n]) > 0
