"""FMCW files: the raw FMCW cube of an ``.npy``, ``.npz`` or ``.mat`` file, and the
chirp parameters and track it states (the signal processing that turns a cube into
slow time is :mod:`microdoppler.importing.fmcw`; the parameter and track helpers are
those of slow-time recordings, :mod:`microdoppler.io.recordings`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from .recordings import PARAM_TYPES, TRACK_VARS, _real_vector, convert

#: variable names (lower case) of an FMCW .mat / .npz read as its parameters
FMCW_ALIASES = {
    "chirp_rate_hz": ("chirp_rate_hz", "chirp_rate", "chirps_per_s", "prf_hz", "prf"),
    "bandwidth_hz": ("bandwidth_hz", "bandwidth", "bw", "sweep_bandwidth_hz"),
    "sample_rate_hz": ("sample_rate_hz", "sample_rate", "fs", "adc_rate_hz", "adc_sample_rate_hz"),
    "carrier_hz": (
        "carrier_hz",
        "fc",
        "carrier_frequency",
        "carrier_frequency_hz",
        "center_frequency",
        "centre_frequency_hz",
    ),
}
#: file variables that mark a .mat / .npz as FMCW (the others are shared with slow-time files)
FMCW_MARKERS = (
    "chirp_rate_hz",
    "chirp_rate",
    "chirps_per_s",
    "bandwidth_hz",
    "bandwidth",
    "bw",
    "sweep_bandwidth_hz",
    "adc_rate_hz",
    "adc_sample_rate_hz",
)
CUBE_EXPECTED = "an FMCW cube [n_chirps, n_samples] or [n_chirps, n_samples, n_channels], real or complex"


@dataclass
class FmcwFile:
    """An FMCW recording read from a file: the cube, and the parameters the file states.

    Attributes
    ----------
    path : Path
    format : str
        ``npy``, ``npz``, ``mat-v5`` or ``mat-v7.3``.
    cube : ndarray [n_chirps, n_samples, n_channels]
    metadata, fields : dict
        As :class:`~microdoppler.io.recordings.Recording`'s, FMCW keys included.
    track : dict or None
    variable : str
    """

    path: Path
    format: str
    cube: np.ndarray
    metadata: dict = field(default_factory=dict)
    fields: dict = field(default_factory=dict)
    track: dict | None = None
    variable: str = "array"


def cube_array(a, source, where: str) -> np.ndarray:
    """Check one array as an FMCW cube; returns it as [n_chirps, n_samples, n_channels].

    Raises
    ------
    InputError
        Not numeric, not 2-D or 3-D, too few samples per chirp, or NaN/inf (naming
        the first bad chirp, sample and channel).
    """
    a = np.asarray(a)
    if a.dtype.names and set(a.dtype.names) >= {"real", "imag"}:
        a = a["real"] + 1j * a["imag"].astype(np.float64)
    if a.dtype.kind not in "iufc":
        raise InputError(source, where, f"has dtype {a.dtype}", "numeric beat samples (" + CUBE_EXPECTED + ")")
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3:
        raise InputError(source, where, f"has shape {a.shape}", CUBE_EXPECTED)
    n_chirps, n_samples, n_ch = a.shape
    if n_samples < 8:
        raise InputError(
            source,
            where,
            f"has shape {a.shape[:2] if n_ch == 1 else a.shape}: {n_samples} samples per chirp",
            "at least 8 fast-time samples per chirp (axis 1; " + CUBE_EXPECTED + ")",
        )
    if n_chirps < 32:
        raise InputError(source, where, f"has {n_chirps} chirps (axis 0)", "at least 32 chirps")
    bad = ~np.isfinite(a)
    if bad.any():
        c, s, ch = (int(x) for x in np.argwhere(bad)[0])
        raise InputError(
            source,
            where,
            f"contains NaN or infinite values (first at chirp {c}, sample {s}, channel {ch})",
            "finite beat samples",
        )
    return a


def looks_fmcw(arrays: dict) -> bool:
    """Whether named arrays (a .mat / .npz) state FMCW parameters (a variable of
    :data:`FMCW_MARKERS`). A cube-shaped array alone is not taken for FMCW: without
    the chirp parameters it could not be read anyway, and the slow-time reader's error
    says what to add."""
    return any(n.lower() in FMCW_MARKERS for n in arrays)


def fmcw_from_arrays(path: Path, fmt: str, arrays: dict, *, variable: str | None = None) -> FmcwFile:
    """The cube, parameters and track of named arrays (see :func:`looks_fmcw`)."""
    names_of = {a: k for k, al in FMCW_ALIASES.items() for a in al}
    for k in PARAM_TYPES:
        if k != "n_samples":  # in an FMCW file it could mean samples per chirp: not read
            names_of.setdefault(k, k)
    md, fields, track = {}, {}, {}
    for name, v in arrays.items():
        key = names_of.get(name.lower())
        if key is not None and (isinstance(v, str) or np.asarray(v).size == 1) and key not in md:
            md[key] = convert(key, v, path, name)
            fields[key] = name
        elif name.lower() in TRACK_VARS:
            track[name.lower()] = _real_vector(v, path, name).astype(np.float64)
    used = set(fields.values()) | {n for n in arrays if n.lower() in TRACK_VARS}
    cands = [n for n, v in arrays.items() if n not in used and not isinstance(v, str) and np.asarray(v).size > 1]
    if variable:
        names = [s.strip() for s in str(variable).split(",")]
        for nm in names:
            if nm not in arrays or isinstance(arrays[nm], str):
                raise InputError(
                    path, nm, "no such array", "--variable one of: " + (", ".join(sorted(cands)) or "none")
                )
        if len(names) == 2:
            i, q = (np.asarray(arrays[nm]) for nm in names)
            if np.iscomplexobj(i) or np.iscomplexobj(q) or i.shape != q.shape:
                raise InputError(
                    path, ",".join(names), f"have shapes {i.shape}, {q.shape}", "two real arrays I, Q of one shape"
                )
            cube = cube_array(i.astype(np.float64) + 1j * q.astype(np.float64), path, ",".join(names))
        elif len(names) == 1:
            cube = cube_array(arrays[names[0]], path, names[0])
        else:
            raise InputError("--variable", "value", f"is {variable!r}", "NAME or NAME_I,NAME_Q")
        chosen = ",".join(names)
    else:
        lower = {n.lower(): n for n in cands}
        if len(cands) == 1:
            chosen = cands[0]
        elif "cube" in lower or "iq" in lower or "data" in lower:
            chosen = lower.get("cube") or lower.get("iq") or lower["data"]
        elif not cands:
            raise InputError(path, "variables", "hold no data array", CUBE_EXPECTED)
        else:
            raise InputError(
                path,
                "variables",
                f"hold several arrays ({', '.join(sorted(cands))})",
                "--variable NAME (or NAME_I,NAME_Q) to pick the FMCW cube",
            )
        cube = cube_array(arrays[chosen], path, chosen)
    trk = None
    if track:
        if not {"track_time_s", "track_range_m"} <= set(track):
            raise InputError(
                path, next(iter(track)), "given without track_time_s and track_range_m", "both arrays, or neither"
            )
        trk = {
            "time_s": track["track_time_s"],
            "range_m": track["track_range_m"],
            "radial_velocity_mps": track.get("track_radial_velocity_mps"),
            "source": "file arrays track_*",
        }
    return FmcwFile(path=path, format=fmt, cube=cube, metadata=md, fields=fields, track=trk, variable=chosen)
