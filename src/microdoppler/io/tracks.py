"""Track CSV files: a target's range over time on the radar's clock."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError

EXPECTED = "a track CSV with columns time_s, range_m"


def read_track_table(path) -> tuple[np.ndarray, np.ndarray]:
    """Read and check a track CSV (``time_s``, ``range_m``).

    Parameters
    ----------
    path : str or Path
        The CSV file; other columns are ignored here.

    Returns
    -------
    time_s : ndarray, float64 [n]
        Strictly increasing times [s], as in the file.
    range_m : ndarray, float64 [n]
        Ranges [m], all > 0.

    Raises
    ------
    InputError
        The file is missing or not CSV, a column is missing or holds non-finite
        values, the times do not increase over at least two rows, or a range is <= 0.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(path, "file", "does not exist", EXPECTED)
    try:
        df = pd.read_csv(path)
    except Exception as exc:
        raise InputError(path, "file", f"cannot be parsed as CSV ({type(exc).__name__})", EXPECTED) from None
    cols = {}
    for c in ("time_s", "range_m"):
        if c not in df.columns:
            raise InputError(path, c, "column missing", "columns time_s [s], range_m [m]")
        v = pd.to_numeric(df[c], errors="coerce").to_numpy(np.float64)
        if not np.all(np.isfinite(v)):
            raise InputError(path, c, "has non-numeric, NaN or infinite values", "finite numbers")
        cols[c] = v
    t, r = cols["time_s"], cols["range_m"]
    if len(t) < 2 or np.any(np.diff(t) <= 0):
        raise InputError(path, "time_s", "is not strictly increasing with >= 2 rows", "increasing times [s]")
    if np.any(r <= 0):
        raise InputError(path, "range_m", "has non-positive ranges", "ranges > 0 m")
    return t, r
