"""FMCW files -> flight-zarr/1: the file glue of ``microdoppler import`` for raw FMCW
cubes (:mod:`microdoppler.io.fmcw` does the signal processing; the parameter and
track helpers are those of slow-time recordings, :mod:`microdoppler.io.recordings`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from .fmcw import (
    CUBE_EXPECTED,
    FMCW_ALIASES,
    FMCW_REQUIRED,
    FmcwParameters,
    background_slow_time,
    cube_array,
    process_fmcw,
)
from .recordings import (
    OPTION,
    PARAM_TYPES,
    TRACK_VARS,
    Recording,
    _real_vector,
    build_flight,
    check_required,
    constant_track,
    convert,
    explicit_track,
    read_arrays,
    resolve_parameters,
    set_flight_id,
)


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


# ---- import -------------------------------------------------------------------------


def import_fmcw(
    path,
    fmt: str,
    arrays: dict,
    *,
    options: dict,
    sidecar: dict,
    variable: str | None = None,
    default_flight_id: str | None = None,
    background=None,
    noise_s=None,
):
    """An FMCW recording -> ``(flight, warnings)`` (what
    :func:`~microdoppler.io.importing.import_recording` does for a cube).

    Parameters come as for a slow-time recording (option > sidecar > file), plus
    ``chirp_rate_hz`` (or ``prf_hz``: the chirp rate becomes the store's ``prf_hz``),
    ``bandwidth_hz``, ``sample_rate_hz`` and optionally ``range_bin``, ``cpi_chirps``
    and ``beat_sign``. The track is the one the range bins give, unless the options,
    the sidecar or the file give one (which then wins, with a warning).
    ``background`` names a target-free FMCW recording of the same shape, taken
    through the same bins and channel weights.
    """
    path = Path(path)
    ff = fmcw_from_arrays(path, fmt, arrays, variable=variable)
    params, sources, warns = resolve_parameters(ff, options, sidecar)
    chirp, prf = params.get("chirp_rate_hz"), params.get("prf_hz")
    if chirp is not None and prf is not None and not math.isclose(chirp, prf, rel_tol=1e-9):
        raise InputError(
            path,
            "prf_hz",
            f"is {prf:g} ({sources['prf_hz']}) but chirp_rate_hz is {chirp:g} ({sources['chirp_rate_hz']})",
            "one chirp rate: an FMCW recording's prf_hz is its chirp rate",
        )
    if chirp is None and prf is not None:
        params["chirp_rate_hz"], sources["chirp_rate_hz"] = prf, sources["prf_hz"]
    for key in FMCW_REQUIRED:
        if key not in params:
            raise InputError(
                path,
                key,
                f"missing: an FMCW cube of shape {ff.cube.shape} needs it, and it is not in "
                "the file, a sidecar or the options",
                f"{OPTION[key]} or the sidecar key {key}",
            )
    params["prf_hz"], sources["prf_hz"] = params["chirp_rate_hz"], sources["chirp_rate_hz"]
    set_flight_id(ff, params, sources, default_flight_id)
    check_required(ff, params)
    p = FmcwParameters(
        chirp_rate_hz=params["chirp_rate_hz"],
        bandwidth_hz=params["bandwidth_hz"],
        sample_rate_hz=params["sample_rate_hz"],
        carrier_hz=params["carrier_hz"],
        n_samples=ff.cube.shape[1],
    )
    beat = params.get("beat_sign", "positive")
    res = process_fmcw(
        ff.cube, p, cpi_chirps=params.get("cpi_chirps"), range_bin=params.get("range_bin"), beat_sign=beat, source=path
    )
    duration = ff.cube.shape[0] / p.chirp_rate_hz
    derived = {
        "time_s": res.track["time_s"],
        "range_m": res.track["range_m"],
        "radial_velocity_mps": res.track["radial_velocity_mps"],
        "source": f"FMCW range bins {res.info['bins_min']}-{res.info['bins_max']}",
    }
    track = explicit_track(options, sidecar, duration)
    if track is None and ff.track is not None:
        track = dict(ff.track)
    if track is None and "range_m" in ff.metadata:
        track = constant_track(ff.metadata["range_m"], duration, f"constant range file {ff.fields['range_m']}")
    if track is not None:
        warns.append(f"{track['source']} replaces the track from the FMCW range bins")
    else:
        track = derived
    sources.pop("range_m", None)
    bg = None
    if background:
        bpath = Path(background)
        bfmt, barrays = read_arrays(bpath)
        bff = fmcw_from_arrays(bpath, bfmt, barrays, variable=variable)
        for key in FMCW_REQUIRED:
            v, want = bff.metadata.get(key), getattr(p, key)
            if v is not None and not math.isclose(v, want, rel_tol=1e-9):
                raise InputError(bpath, bff.fields[key], f"is {v:g}", f"{want:g} as the recording's {key}")
        bg = background_slow_time(bff.cube, p, res, beat_sign=beat, source=bpath)
    info = {"variable": ff.variable, "fmcw": {**res.info, "carrier_hz": p.carrier_hz}}
    rec = Recording(
        path=path,
        format=ff.format,
        layout=f"fmcw-{res.info['input']}",
        iq=res.iq,
        metadata=ff.metadata,
        fields=ff.fields,
        info=info,
    )
    return build_flight(rec, params, track, sources=sources, warnings_=warns, background=bg, noise_s=noise_s)
