"""The local noise floor of a periodogram: a low percentile over a sliding window,
robust to the lines that fill the bins around a drone's body (rotor speeds from the
radar, :mod:`microdoppler.rotors`)."""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

#: local noise floor (step 1, :func:`local_floor_db`): the 20th percentile of 129 bins
#: (~230 Hz at 7.3 kHz / 4096) every 16 bins; a low percentile ignores the lines that
#: fill the bins around a drone's body
FLOOR_WINDOW_BINS = 129
FLOOR_STEP_BINS = 16
FLOOR_PERCENTILE = 20.0


def local_floor_db(
    power_db: np.ndarray,
    *,
    window_bins: int = FLOOR_WINDOW_BINS,
    step_bins: int = FLOOR_STEP_BINS,
    percentile: float = FLOOR_PERCENTILE,
) -> np.ndarray:
    """Mean noise power per bin [dB] of periodogram rows ``power_db`` [k, n_bins].

    A low percentile over ``window_bins`` (centres every ``step_bins``, linear in
    between) is robust to the lines that fill the bins around a drone's body; for
    exponentially distributed noise power the p-th percentile is -ln(1 - p) times
    the mean, which is added back. Returns float32 [k, n_bins].
    """
    p_db = np.atleast_2d(np.asarray(power_db, np.float32))
    k, n = p_db.shape
    h = window_bins // 2
    pad = np.pad(p_db, ((0, 0), (h, h)), mode="reflect")
    centres = np.arange(0, n, step_bins)
    if centres[-1] != n - 1:
        centres = np.append(centres, n - 1)
    q = int(np.floor(percentile / 100 * (2 * h)))
    win = sliding_window_view(pad, 2 * h + 1, axis=1)[:, centres]
    low = np.partition(win, q, axis=2)[:, :, q]
    out = np.empty((k, n), np.float32)
    x = np.arange(n)
    for i in range(k):
        out[i] = np.interp(x, centres, low[i])
    return out - np.float32(10 * np.log10(-np.log(1 - percentile / 100)))
