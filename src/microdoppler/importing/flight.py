"""One entry point for ``microdoppler import``: a recording of any supported kind ->
a checked flight-zarr/1 flight.

The file is read by :mod:`microdoppler.io` (slow-time I/Q:
:mod:`microdoppler.io.recordings`; raw FMCW cubes: :mod:`microdoppler.io.fmcw_files`);
a cube is turned into the target's slow time and track
(:mod:`microdoppler.importing.fmcw`); :func:`build_flight` measures the receiver's I/Q
balance (:mod:`microdoppler.importing.iqbalance`) and validates the flight; the declared
set-up is checked against physics (:mod:`microdoppler.importing.plausibility`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.flightzarr import SCHEMA, Flight
from ..io.fmcw_files import fmcw_from_arrays, looks_fmcw
from ..io.recordings import (
    DRONE_REQUIRED,
    FMCW_PARAM_TYPES,
    OPTION,
    Recording,
    _level_value,
    check_required,
    constant_track,
    detect_format,
    explicit_track,
    explicit_track_given,
    finish_track,
    read_arrays,
    read_recording,
    recording_from_arrays,
    resolve_parameters,
    set_flight_id,
)
from .fmcw import FMCW_REQUIRED, FmcwParameters, background_slow_time, process_fmcw
from .iqbalance import iq_sanity, sanity_warnings
from .plausibility import check_setup, mark

SPEED_OF_LIGHT_MPS = 299_792_458.0


def import_recording(
    path,
    *,
    options: dict | None = None,
    sidecar: dict | None = None,
    layout: str | None = None,
    variable: str | None = None,
    default_flight_id: str | None = None,
    background=None,
    force: bool = False,
) -> tuple[Flight, list[str]]:
    """Read ``path`` and return ``(flight, warnings)``.

    ``options`` and ``sidecar`` map keys of
    ``microdoppler.io.recordings.SIDECAR_KEYS`` to ``(value, label)`` (the label
    names the option, table cell or sidecar key in messages); options win over the
    sidecar, both over the file's metadata. The track is the first of: ``track`` (CSV
    path) or ``range_m`` (constant, a staring recording) among the options, then the
    sidecar's, then the file's own track arrays or ``range_m``. ``background`` names a
    target-free recording of the same cells (same format and layout), stored as
    ``background/iq`` and used for the I/Q balance; the options' or sidecar's
    ``noise_segment_s`` names a target-free stretch of the recording.

    A raw FMCW cube (FMCW parameters given, or a file that states them) is turned into
    the target's slow time and track first (``microdoppler.importing.flight.import_fmcw``).

    Parameters
    ----------
    path : str or path-like
        The recording: SigMF, MATLAB ``.mat``, NumPy ``.npz`` or ``.npy``.
    options, sidecar : dict, optional
        ``{key: (value, label)}``: the radar's and target's parameters (``prf_hz``
        [Hz], ``carrier_hz`` [Hz], ``target``, ``radar_id``, the rotor geometry, ...).
    layout : str, optional
        How I/Q is stored (``complex``, ``interleaved``, ...); default from the file.
    variable : str, optional
        The array holding the samples in a ``.mat`` or ``.npz`` file.
    default_flight_id : str, optional
        The flight id when neither the file nor the options name one (default: the
        file's stem).
    background : str or path-like, optional
        A target-free recording of the same cells.
    force : bool
        Keep a set-up that fails the plausibility check, with the warnings stored in
        the flight's ``plausibility_warnings`` attribute (and in the warnings
        returned), instead of raising.

    The declared set-up is checked against physics and the recording
    (``microdoppler.importing.plausibility.check_setup``) before anything is returned.

    Returns
    -------
    flight : Flight
        The flight (``iq`` complex64 [n_pulses], a track, the attributes).
    warnings : list of str
        What the import noticed and could not fix (I/Q imbalance, ...).

    Raises
    ------
    microdoppler.errors.InputError
        Naming the file, the field and what was expected (a parameter missing
        everywhere, an unreadable file, an implausible set-up without ``force``, ...).

    See Also
    --------
    microdoppler.io.write_flight, microdoppler.io.read_flight

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from microdoppler.importing import import_recording
    >>> path = Path(tempfile.mkdtemp()) / "stand.npz"
    >>> rng = np.random.default_rng(0)
    >>> np.savez(path, iq=(rng.standard_normal(5000) + 1j * rng.standard_normal(5000)).astype(np.complex64))
    >>> params = dict(prf_hz=5000.0, carrier_hz=3.3e9, target="drone", radar_id="cw_s_band", range_m=25.0,
    ...               drone_model="quad", n_motors=4, n_blades=2, blade_length_m=0.12)
    >>> flight, warnings = import_recording(path, options={k: (v, k) for k, v in params.items()})
    >>> flight.flight_id, flight.prf_hz, flight.iq.shape
    ('stand', 5000.0, (5000,))
    """
    options, sidecar = dict(options or {}), dict(sidecar or {})
    if layout is None:
        layout = _level_value(options, sidecar, "layout")
    if variable is None:
        variable = _level_value(options, sidecar, "variable")
    noise_s = _level_value(options, sidecar, "noise_segment_s")
    path = Path(path)
    fmcw, read = wants_fmcw(path, options, sidecar, variable)
    if fmcw:
        if layout is not None:
            raise InputError(
                path,
                "--layout",
                f"is {layout!r} for an FMCW cube",
                "no --layout (a real cube is a real beat signal, a complex one I/Q)",
            )
        flight, warns = import_fmcw(
            path,
            *read,
            options=options,
            sidecar=sidecar,
            variable=variable,
            default_flight_id=default_flight_id,
            background=background,
            noise_s=noise_s,
        )
    else:
        flight, warns = import_slow_time(
            path,
            read,
            options=options,
            sidecar=sidecar,
            layout=layout,
            variable=variable,
            default_flight_id=default_flight_id,
            background=background,
            noise_s=noise_s,
        )
    implausible = check_setup(path, flight.attrs, len(flight.iq), force=force)
    return mark(flight, implausible), warns + implausible


def wants_fmcw(path, options: dict, sidecar: dict, variable: str | None = None) -> tuple[bool, tuple | None]:
    """Whether ``path`` is to be read as an FMCW cube: an FMCW parameter among the
    options or the sidecar, or a file that looks like one (:func:`~microdoppler.io.fmcw_files.looks_fmcw`).
    Returns ``(fmcw, (format, arrays) or None)`` (the arrays read, for a .npy/.npz/.mat)."""
    path = Path(path)
    given = any(_level_value(options, sidecar, k) is not None for k in FMCW_PARAM_TYPES)
    if detect_format(path) == "sigmf":
        if given:
            raise InputError(
                path,
                "file",
                "is SigMF, but FMCW parameters were given",
                "an FMCW cube as .npy, .npz or .mat (SigMF holds slow-time I/Q)",
            )
        return False, None
    fmt, arrays = read_arrays(path)
    return given or looks_fmcw(arrays), (fmt, arrays)


def import_slow_time(
    path,
    read,
    *,
    options: dict,
    sidecar: dict,
    layout: str | None,
    variable: str | None,
    default_flight_id: str | None,
    background,
    noise_s,
) -> tuple[Flight, list[str]]:
    """A slow-time recording -> ``(flight, warnings)``; ``read`` is ``(format, arrays)``
    when :func:`wants_fmcw` already read the file, else None. Called by
    :func:`microdoppler.importing.import_recording`, which documents the arguments."""
    path = Path(path)
    if read is None:
        rec = read_recording(path, variable=variable, layout=layout)
    else:
        rec = recording_from_arrays(path, *read, variable=variable, layout=layout)
    params, sources, warns = resolve_parameters(rec, options, sidecar)
    set_flight_id(rec, params, sources, default_flight_id)
    no_track = not explicit_track_given(options, sidecar) and rec.track is None and "range_m" not in rec.metadata
    check_required(rec, params, track_missing=no_track)
    duration = len(rec.iq) / float(params["prf_hz"])
    track = explicit_track(options, sidecar, duration)
    if track is not None and rec.track is not None:
        warns.append(f"{track['source']} replaces the file's own track arrays")
    if track is None:
        if rec.track is not None:
            track = dict(rec.track)
        elif "range_m" in rec.metadata:
            track = constant_track(rec.metadata["range_m"], duration, f"constant range file {rec.fields['range_m']}")
        else:
            raise InputError(
                rec.path,
                "track",
                "missing: no track in the file, a sidecar or the options",
                "--track CSV (time_s, range_m) or --range-m for a staring recording",
            )
    sources.pop("range_m", None)
    bg = None
    if background:
        bg = read_recording(background, variable=variable, layout=layout).iq
        if len(bg) != len(rec.iq):
            raise InputError(
                background,
                "samples",
                f"has {len(bg)}",
                f"{len(rec.iq)} samples, as the recording (background/iq pairs pulse by pulse)",
            )
    return build_flight(rec, params, track, sources=sources, warnings_=warns, background=bg, noise_s=noise_s)


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
    :func:`~microdoppler.importing.import_recording` does for a cube).

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


def build_flight(
    rec: Recording,
    params: dict,
    track: dict,
    *,
    sources: dict | None = None,
    warnings_: list[str] | None = None,
    background: np.ndarray | None = None,
    noise_s: tuple[float, float] | None = None,
) -> tuple[Flight, list[str]]:
    """A validated :class:`Flight` from a recording, its parameters and its track.

    Checks the required parameters, ``n_samples`` against the data, and the
    receiver's I/Q balance (:func:`~microdoppler.importing.iqbalance.iq_sanity`: from
    ``background`` (stored as ``background/iq``), else from the recording's
    ``noise_s`` = ``(start, end)`` [s] stretch, else from the body line when it lies
    well away from 0 Hz, else not measurable); returns the flight and the list of
    warnings (also in ``attrs["import"]["warnings"]``).
    """
    from ..io.flightzarr import _check_attrs, _check_consistency

    warns = list(warnings_ or [])
    check_required(rec, params)
    n = len(rec.iq)
    if "n_samples" in params and params["n_samples"] != n:
        where = (sources or {}).get("n_samples", "metadata")
        raise InputError(
            rec.path,
            "n_samples",
            f"the data holds {n} samples but {where} says {params['n_samples']}",
            f"{params['n_samples']} samples",
        )
    prf, carrier = float(params["prf_hz"]), float(params["carrier_hz"])
    duration = n / prf
    if noise_s is not None and noise_s[1] > duration + 1e-9:
        raise InputError(
            rec.path,
            "noise_segment_s",
            f"is {noise_s[0]:g}:{noise_s[1]:g} s, beyond the recording's {duration:.3f} s",
            "a stretch within the recording",
        )
    track = finish_track(track, track.get("source", rec.path))
    t = track["time_s"]
    if t[0] > 1.0 or t[-1] < duration - 1.0:
        warns.append(
            f"the track ({track['source']}) covers {t[0]:.2f}-{t[-1]:.2f} s of the recording's 0-{duration:.2f} s"
        )
    target = params["target"]
    if target != "drone":
        for k in DRONE_REQUIRED:
            if k in params and not str((sources or {}).get(k, "file")).startswith("file"):
                warns.append(f"{sources[k]} = {params[k]!r} is ignored: the target is {target}, not a drone")
    sanity = iq_sanity(
        rec.iq,
        prf,
        SPEED_OF_LIGHT_MPS / carrier,
        track if target != "none" and np.any(track["radial_velocity_mps"] != 0) else None,
        background=background,
        noise_s=noise_s,
    )
    warns += sanity_warnings(sanity)
    attrs = {
        "schema": SCHEMA,
        "flight_id": params["flight_id"],
        "target": target,
        "radar_id": params["radar_id"],
        "prf_hz": prf,
        "carrier_hz": carrier,
    }
    if target == "drone":
        attrs.update({k: params[k] for k in DRONE_REQUIRED})
    attrs["import"] = {
        "source_file": str(rec.path),
        "format": rec.format,
        "layout": rec.layout,
        **rec.info,
        "n_samples": n,
        **sanity,
        "track": track["source"],
        "parameter_sources": dict(sorted((sources or {}).items())),
        "warnings": warns,
    }
    if noise_s is not None:
        attrs["import"]["noise_segment_s"] = [float(noise_s[0]), float(noise_s[1])]
    json.dumps(attrs)  # zarr attributes are JSON
    _check_attrs(rec.path, attrs)
    flight = Flight(
        attrs=attrs,
        iq=rec.iq,
        track_time_s=track["time_s"],
        track_range_m=track["range_m"],
        track_radial_velocity_mps=track["radial_velocity_mps"],
        background_iq=background,
    )
    _check_consistency(rec.path, attrs, flight.arrays())
    return flight, warns
