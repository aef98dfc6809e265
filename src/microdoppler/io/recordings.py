"""Recordings in other formats: the readers of ``microdoppler import``.

Readers (:func:`read_sigmf`, :func:`read_mat`, :func:`read_npy`, :func:`read_npz`,
or :func:`read_recording` by suffix) return a :class:`Recording`: the slow-time I/Q
as complex64 plus a metadata dict of the radar parameters the file itself states
(``prf_hz``, ``carrier_hz``, ...), each with the field it came from.
:func:`resolve_parameters` merges them with a YAML sidecar and command-line options
(option > sidecar > file; an option or sidecar value that contradicts the file's
own metadata wins with a warning). Turning a recording into a validated
:class:`~microdoppler.io.flightzarr.Flight` (the receiver's I/Q balance, the FMCW
range processing of raw cubes, read by :mod:`microdoppler.io.fmcw_files`, the
plausibility checks) is :mod:`microdoppler.importing`
(:func:`microdoppler.importing.import_recording`).

What each format contributes
----------------------------
SigMF (``.sigmf-meta`` + ``.sigmf-data``, read with the ``sigmf`` package)
    ``core:sample_rate`` -> ``prf_hz`` (one sample per pulse: the recording is the
    slow-time sequence of the target's cell), ``captures[0].core:frequency`` ->
    ``carrier_hz``, ``core:hw`` -> ``radar_id``, an annotation ``core:label`` of
    ``drone``/``bird``/``none`` -> ``target``; any parameter under the
    ``microdoppler:`` namespace (``microdoppler:radar_id``, ``microdoppler:n_motors``,
    ...) in the global object. Complex datatypes (``cf32_le``, ``ci16_le``, ...; fixed
    point is kept in ADC counts, unsigned types are re-centred) are the ``complex``
    layout; a real datatype with ``core:num_channels`` 2 is ``iq-columns``.
MATLAB ``.mat``
    v5 through :func:`scipy.io.loadmat`; v7.3 (HDF5) through ``h5py`` (MATLAB's
    column-major arrays are transposed back; complex arrays are compound
    ``real``/``imag`` datasets). Any HDF5 file named ``.mat`` is read the same way.
NumPy ``.npy`` / ``.npz``
    One array, or named arrays as in a ``.mat``.

In ``.mat`` and ``.npz`` files, scalar variables named like the parameters
(``prf_hz``, ``carrier_hz``, ``radar_id``, ..., ``n_samples``; also ``fs`` /
``sample_rate`` / ``prf`` and ``fc`` / ``carrier_frequency``) are the file's
metadata, and arrays ``track_time_s``, ``track_range_m`` (and optionally
``track_radial_velocity_mps``) its track. The I/Q is the one remaining array, the
pair ``I``, ``Q``, or what ``variable`` names (``NAME`` or ``NAME_I,NAME_Q``).
"""

from __future__ import annotations

import json
import math
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from .flightzarr import FLIGHT_ID_RE, TARGETS

FORMATS = ("sigmf", "mat", "npy", "npz")
LAYOUTS = ("complex", "iq-columns")
#: the beat's sign of an FMCW recording (see :mod:`microdoppler.importing.fmcw`)
BEAT_SIGNS = ("positive", "negative")
#: parameters of an FMCW recording (besides the slow-time ones), and their types
FMCW_PARAM_TYPES = {
    "chirp_rate_hz": float,
    "bandwidth_hz": float,
    "sample_rate_hz": float,
    "range_bin": int,
    "cpi_chirps": int,
    "beat_sign": str,
}
#: parameters a file, a sidecar, a batch row or an option may give, and their types
PARAM_TYPES = {
    "prf_hz": float,
    "carrier_hz": float,
    "radar_id": str,
    "target": str,
    "drone_model": str,
    "n_motors": int,
    "n_blades": int,
    "blade_length_m": float,
    "range_m": float,
    "flight_id": str,
    "n_samples": int,
    **FMCW_PARAM_TYPES,
}
#: further keys of a sidecar / batch row (paths and reading options; ``noise_segment_s``:
#: ``START:END`` [s] of the recording that holds no target, for the I/Q balance)
EXTRA_KEYS = ("track", "layout", "variable", "noise_segment_s")
SIDECAR_KEYS = tuple(PARAM_TYPES) + EXTRA_KEYS
#: the command-line option of each parameter
OPTION = {k: "--" + k.replace("_", "-") for k in (*PARAM_TYPES, *EXTRA_KEYS)}
REQUIRED = ("prf_hz", "carrier_hz", "radar_id", "target")
DRONE_REQUIRED = ("drone_model", "n_motors", "n_blades", "blade_length_m")
#: variable names (lower case) read as metadata in .mat / .npz files
ALIASES = {
    "prf_hz": ("prf_hz", "prf", "fs", "sample_rate", "sample_rate_hz"),
    "carrier_hz": ("carrier_hz", "fc", "carrier_frequency", "carrier_frequency_hz", "center_frequency"),
    **{k: (k,) for k in PARAM_TYPES if k not in ("prf_hz", "carrier_hz") and k not in FMCW_PARAM_TYPES},
}
TRACK_VARS = ("track_time_s", "track_range_m", "track_radial_velocity_mps")
SIGMF_DATATYPE_RE = re.compile(r"^(c|r)(f32|f64|i32|i16|u32|u16|i8|u8)(_le|_be)?$")
SIGMF_NS = "microdoppler:"
SHAPE_EXPECTED = (
    "a complex vector [n] or two real columns I, Q [n, 2]; an FMCW cube [chirps, samples(, channels)] "
    "needs --chirp-rate-hz, --bandwidth-hz and --sample-rate-hz"
)


@dataclass
class Recording:
    """One recording read from a file.

    Attributes
    ----------
    path : Path
        The file named by the user.
    format : str
        ``sigmf``, ``mat-v5``, ``mat-v7.3``, ``npy`` or ``npz``.
    layout : str
        ``complex`` or ``iq-columns`` (how the file stores the I/Q).
    iq : ndarray, complex64 [n]
    metadata : dict
        Parameters the file states (names of :data:`PARAM_TYPES`), typed.
    fields : dict
        For each entry of ``metadata``: where in the file it came from.
    track : dict or None
        ``time_s``, ``range_m`` and optionally ``radial_velocity_mps`` arrays from the file.
    info : dict
        Provenance for the store's ``import`` attribute (datatype, variable, ...).
    """

    path: Path
    format: str
    layout: str
    iq: np.ndarray
    metadata: dict = field(default_factory=dict)
    fields: dict = field(default_factory=dict)
    track: dict | None = None
    info: dict = field(default_factory=dict)


# ---- values ------------------------------------------------------------------------


def convert(key: str, value, source, where: str):
    """Type-check one parameter value; ``source``/``where`` name it in errors."""
    typ = PARAM_TYPES[key]
    if isinstance(value, np.ndarray):
        if value.size != 1:
            raise InputError(source, where, f"has {value.size} values", f"one {typ.__name__}")
        value = value.reshape(-1)[0]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bytes):
        value = value.decode("utf-8", "replace")
    if typ is str:
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            raise InputError(source, where, f"is {value!r}", "a string")
        value = str(value).strip()
        if not value:
            raise InputError(source, where, "is empty", "a non-empty string")
        if key == "target" and value not in TARGETS:
            raise InputError(source, where, f"is {value!r}", " or ".join(TARGETS))
        if key == "beat_sign" and value not in BEAT_SIGNS:
            raise InputError(source, where, f"is {value!r}", " or ".join(BEAT_SIGNS))
        if key == "flight_id" and not FLIGHT_ID_RE.match(value):
            raise InputError(source, where, f"is {value!r}", "a flight id of [A-Za-z0-9_.-]+")
        return value
    if isinstance(value, bool):
        raise InputError(source, where, f"is {value!r}", f"a {typ.__name__}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(source, where, f"is {value!r}", "a number") from None
    if typ is int:
        if not (math.isfinite(v) and v == int(v) and v >= 1):
            raise InputError(source, where, f"is {value!r}", "an integer >= 1")
        return int(v)
    if not (math.isfinite(v) and v > 0):
        raise InputError(source, where, f"is {value!r}", "a finite number > 0")
    if key == "blade_length_m" and v >= 5:
        raise InputError(source, where, f"is {v:g}", "a blade length in (0, 5) m")
    return v


def _same(a, b) -> bool:
    if isinstance(a, float) or isinstance(b, float):
        return math.isclose(float(a), float(b), rel_tol=1e-9)
    return a == b


def _brief(exc: BaseException) -> str:
    """``Type: message`` of an exception, one line, at most ~100 characters, no parentheses."""
    msg = re.sub(r"[()\s]+", " ", str(exc)).strip()
    return f"{type(exc).__name__}: {msg[:90]}" if msg else type(exc).__name__


def _index(value, source, where: str) -> int:
    """A sample index or count from SigMF metadata (an integer >= 0)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0 or value != int(value):
        raise InputError(source, where, f"is {value!r}", "an integer >= 0")
    return int(value)


# ---- I/Q arrays ----------------------------------------------------------------------


def _check_finite(iq: np.ndarray, source, where: str) -> None:
    bad = ~np.isfinite(iq)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise InputError(source, where, f"contains NaN or infinite values (first at sample {k})", "finite I/Q samples")


def _real_vector(a: np.ndarray, source, where: str) -> np.ndarray:
    a = np.asarray(a)
    if a.ndim == 2 and 1 in a.shape:
        a = a.reshape(-1)
    if a.ndim != 1 or np.iscomplexobj(a) or not np.issubdtype(a.dtype, np.number):
        raise InputError(source, where, f"has shape {a.shape} and dtype {a.dtype}", "a real vector [n]")
    return a


def iq_from_array(a: np.ndarray, source, where: str, layout: str | None = None) -> tuple[np.ndarray, str]:
    """One array -> (complex64 I/Q, layout). A complex vector is ``complex``; a real
    [n, 2] (or [2, n]) array is ``iq-columns`` (I first). ``layout``, if given, must agree."""
    a = np.asarray(a)
    if a.dtype.names and set(a.dtype.names) >= {"real", "imag"}:  # HDF5 compound complex
        a = a["real"] + 1j * a["imag"].astype(np.float64)
    if a.dtype.kind not in "biufc" or a.dtype.kind == "b":
        raise InputError(source, where, f"has dtype {a.dtype}", "numeric I/Q samples")
    if a.size == 0:
        raise InputError(source, where, f"is empty (shape {a.shape})", SHAPE_EXPECTED)
    if np.iscomplexobj(a):
        found = "complex"
        if a.ndim == 2 and 1 in a.shape:
            a = a.reshape(-1)
        if a.ndim != 1:
            raise InputError(
                source,
                where,
                f"is complex with shape {a.shape}",
                "a complex vector [n] (one channel); an FMCW cube [chirps, samples(, channels)] needs "
                "--chirp-rate-hz, --bandwidth-hz and --sample-rate-hz",
            )
        iq = a
    else:
        found = "iq-columns"
        if a.ndim == 2 and a.shape[1] == 2:
            i, q = a[:, 0], a[:, 1]
        elif a.ndim == 2 and a.shape[0] == 2:
            i, q = a[0], a[1]
        else:
            raise InputError(source, where, f"is real-valued with shape {a.shape}", SHAPE_EXPECTED)
        iq = i.astype(np.float64) + 1j * q.astype(np.float64)
    if layout is not None and layout != found:
        hint = "real I, Q columns" if found == "iq-columns" else "a complex array"
        raise InputError(
            source,
            where,
            f"holds {hint} of shape {a.shape}, not --layout {layout}",
            f"--layout {found} (or no --layout) for this array",
        )
    _check_finite(iq, source, where)
    return np.ascontiguousarray(iq, dtype=np.complex64), found


def iq_from_pair(i: np.ndarray, q: np.ndarray, source, names: tuple[str, str], layout: str | None = None) -> np.ndarray:
    """Two real vectors I, Q -> complex64."""
    if layout == "complex":
        raise InputError(
            source,
            f"{names[0]},{names[1]}",
            "are separate I and Q arrays, not --layout complex",
            "--layout iq-columns (or no --layout) for I and Q arrays",
        )
    i = _real_vector(i, source, names[0])
    q = _real_vector(q, source, names[1])
    if len(i) != len(q):
        raise InputError(source, names[1], f"has {len(q)} samples", f"as many as {names[0]} ({len(i)})")
    if len(i) == 0:
        raise InputError(source, names[0], "is empty", "at least one sample")
    iq = i.astype(np.float64) + 1j * q.astype(np.float64)
    _check_finite(iq, source, f"{names[0]},{names[1]}")
    return iq.astype(np.complex64)


# ---- SigMF -------------------------------------------------------------------------------


def _sigmf_paths(path: Path) -> tuple[Path, Path | None]:
    name = path.name
    for ext in (".sigmf-meta", ".sigmf-data"):
        if name.lower().endswith(ext):
            return path.with_name(name[: -len(ext)] + ".sigmf-meta"), path.with_name(name[: -len(ext)] + ".sigmf-data")
    return path, None


def read_sigmf(path, *, layout: str | None = None) -> Recording:
    """Read a SigMF recording (``.sigmf-meta`` or ``.sigmf-data`` named) with ``sigmf``."""
    from sigmf import hashing
    from sigmf.error import SigMFError
    from sigmf.sigmffile import dtype_info, fromfile

    path = Path(path)
    meta_path, _ = _sigmf_paths(path)
    if not meta_path.is_file():
        raise InputError(meta_path, "file", "does not exist", "a SigMF metadata file (.sigmf-meta) beside the data")
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise InputError(meta_path, "file", f"is not valid JSON ({_brief(exc)})", "SigMF metadata (JSON)") from None
    if not isinstance(meta, dict) or not isinstance(meta.get("global"), dict):
        raise InputError(meta_path, "global", "missing or not an object", "a SigMF metadata object with 'global'")
    glob = meta["global"]
    captures = meta.get("captures") or []
    annotations = meta.get("annotations") or []
    if not isinstance(captures, list) or not all(isinstance(c, dict) for c in captures):
        raise InputError(meta_path, "captures", "is not a list of objects", "SigMF captures")
    if not isinstance(annotations, list) or not all(isinstance(a, dict) for a in annotations):
        raise InputError(meta_path, "annotations", "is not a list of objects", "SigMF annotations")
    dt = glob.get("core:datatype")
    if not isinstance(dt, str) or not SIGMF_DATATYPE_RE.match(dt):
        raise InputError(
            meta_path,
            "global.core:datatype",
            "missing" if dt is None else f"is {dt!r}",
            "a SigMF datatype (c|r)(f32|f64|i32|i16|u32|u16|i8|u8)[_le|_be], e.g. cf32_le, ci16_le",
        )
    dinfo = dtype_info(dt)
    n_ch = glob.get("core:num_channels", 1)
    if not isinstance(n_ch, int) or isinstance(n_ch, bool) or n_ch < 1:
        raise InputError(meta_path, "global.core:num_channels", f"is {n_ch!r}", "an integer >= 1")
    if dinfo["is_complex"]:
        found = "complex"
        if n_ch != 1:
            raise InputError(
                meta_path,
                "global.core:num_channels",
                f"is {n_ch} with complex datatype {dt}",
                "1 (one complex channel: the target's slow-time sequence)",
            )
    else:
        found = "iq-columns"
        if n_ch != 2:
            raise InputError(
                meta_path,
                "global.core:datatype",
                f"is real ({dt}) with {n_ch} channel(s)",
                "a complex datatype (c...), or a real one with core:num_channels 2 (I, Q)",
            )
    if layout is not None and layout != found:
        raise InputError(
            meta_path,
            "global.core:datatype",
            f"is {dt} with {n_ch} channel(s), i.e. {found}",
            f"--layout {found} (or no --layout: SigMF states its layout)",
        )

    with warnings.catch_warnings():  # its warnings (truncation, ...) are checked below as errors
        warnings.simplefilter("ignore")
        try:
            sf = fromfile(str(meta_path), skip_checksum=True, autoscale=False)
        except (SigMFError, ValueError, KeyError, TypeError) as exc:
            raise InputError(
                meta_path, "metadata", f"cannot be read by sigmf ({_brief(exc)})", "SigMF metadata"
            ) from None
    data_path = getattr(sf, "data_file", None)
    if data_path is None or not Path(data_path).is_file():
        raise InputError(
            meta_path,
            "dataset",
            "has no data file",
            f"{meta_path.name[: -len('.sigmf-meta')]}.sigmf-data beside the metadata",
        )
    data_path = Path(data_path)
    sample_size = int(dinfo["sample_size"]) * n_ch
    header = sum(
        _index(c.get("core:header_bytes", 0), meta_path, f"captures[{k}].core:header_bytes")
        for k, c in enumerate(captures)
    )
    trailing = _index(glob.get("core:trailing_bytes", 0), meta_path, "global.core:trailing_bytes")
    nbytes = data_path.stat().st_size - header - trailing
    if nbytes < 0:
        raise InputError(
            data_path,
            "size",
            f"is {nbytes + header + trailing} bytes, less than the "
            f"{header + trailing} header/trailing bytes of the metadata",
            "a complete data file",
        )
    n, rem = divmod(nbytes, sample_size)
    if rem:
        raise InputError(
            data_path,
            "size",
            f"is {nbytes} bytes of samples, not a whole number of {dt} samples "
            f"({sample_size} bytes each; {rem} left over: truncated?)",
            f"a multiple of {sample_size} bytes",
        )
    if n == 0:
        raise InputError(data_path, "size", "holds no samples", "at least one sample")
    for k, a in enumerate(annotations):
        end = _index(a.get("core:sample_start", 0), meta_path, f"annotations[{k}].core:sample_start") + _index(
            a.get("core:sample_count", 0), meta_path, f"annotations[{k}].core:sample_count"
        )
        if end > n:
            raise InputError(
                data_path,
                f"annotations[{k}]",
                f"reaches sample {end}, but the file holds {n} samples (truncated?)",
                f"at least {end} samples",
            )
    for k, c in enumerate(captures):
        start = _index(c.get("core:sample_start", 0), meta_path, f"captures[{k}].core:sample_start")
        if start >= n:
            raise InputError(
                data_path,
                f"captures[{k}].core:sample_start",
                f"is {start}, but the file holds {n} samples (truncated?)",
                f"more than {start} samples",
            )
    digest = glob.get("core:sha512")
    if digest:
        if hashing.calculate_sha512(filename=data_path) != digest:
            raise InputError(
                data_path,
                "global.core:sha512",
                "does not match the data file's checksum",
                "the data the metadata was written for (corrupted or replaced?)",
            )

    raw = sf.read_samples()
    if found == "complex":
        iq = np.asarray(raw).reshape(-1)
        if dinfo["is_unsigned"]:
            iq = iq - (2 ** (int(dinfo["component_size"]) * 8 - 1)) * (1 + 1j)
    else:
        cols = np.asarray(raw, dtype=np.float64).reshape(n, 2)
        if dinfo["is_unsigned"]:
            cols = cols - 2 ** (int(dinfo["component_size"]) * 8 - 1)
        iq = cols[:, 0] + 1j * cols[:, 1]
    iq = np.ascontiguousarray(iq, dtype=np.complex64)
    if len(iq) != n:
        raise InputError(data_path, "samples", f"{len(iq)} read", f"{n} samples")
    _check_finite(iq, data_path, "samples")

    md, fields = {}, {}

    def put(key, value, where):
        if value is None or key in md:
            return
        md[key] = convert(key, value, meta_path, where)
        fields[key] = where

    for key in PARAM_TYPES:  # the microdoppler: namespace first
        put(key, glob.get(SIGMF_NS + key), f"global.{SIGMF_NS}{key}")
    put("prf_hz", glob.get("core:sample_rate"), "global.core:sample_rate")
    freqs = [
        convert("carrier_hz", c["core:frequency"], meta_path, f"captures[{k}].core:frequency")
        for k, c in enumerate(captures)
        if c.get("core:frequency") is not None
    ]
    if any(not _same(f, freqs[0]) for f in freqs):
        raise InputError(
            meta_path,
            "captures.core:frequency",
            f"changes between captures ({freqs[0]:g} ... {freqs[-1]:g} Hz)",
            "one carrier frequency per recording",
        )
    if captures and captures[0].get("core:frequency") is not None:
        put("carrier_hz", captures[0]["core:frequency"], "captures[0].core:frequency")
    put("radar_id", glob.get("core:hw"), "global.core:hw")
    labels = {str(a.get("core:label")).strip().lower() for a in annotations if a.get("core:label") is not None}
    targets = sorted(labels & set(TARGETS))
    if len(targets) == 1:
        put("target", targets[0], "annotations.core:label")
    info = {"datatype": dt, "data_file": str(data_path), "metadata_file": str(meta_path)}
    for k in ("core:description", "core:author", "core:recorder", "core:hw"):
        if isinstance(glob.get(k), str):
            info[k.split(":", 1)[1]] = glob[k]
    if captures and isinstance(captures[0].get("core:datetime"), str):
        info["datetime"] = captures[0]["core:datetime"]
    return Recording(path=path, format="sigmf", layout=found, iq=iq, metadata=md, fields=fields, info=info)


# ---- MATLAB / NumPy: named arrays ---------------------------------------------------


def _mat_v5(path: Path) -> dict:
    import scipy.io

    try:
        raw = scipy.io.loadmat(str(path), squeeze_me=False, chars_as_strings=True)
    except Exception as exc:  # scipy raises many types for a damaged file
        raise InputError(
            path, "file", f"cannot be read as a MATLAB .mat file ({_brief(exc)})", "a MATLAB v5 or v7.3 .mat file"
        ) from None
    out = {}
    for k, v in raw.items():
        if k.startswith("__"):
            continue
        v = np.asarray(v)
        if v.dtype.kind == "U":
            out[k] = "".join(v.reshape(-1).tolist())
        elif v.dtype.kind in "biufc":
            out[k] = v
    return out


def _mat_v73(path: Path) -> dict:
    import h5py

    out = {}
    try:
        with h5py.File(path, "r") as h:
            for k, ds in h.items():
                if k.startswith("#") or not isinstance(ds, h5py.Dataset):
                    continue  # structs, cells and MATLAB's #refs#
                cls = ds.attrs.get("MATLAB_class", b"")
                cls = cls.decode() if isinstance(cls, bytes) else str(cls)
                if ds.attrs.get("MATLAB_empty", 0):
                    continue
                v = np.asarray(ds[()])
                if v.dtype.names and set(v.dtype.names) >= {"real", "imag"}:
                    v = v["real"] + 1j * v["imag"].astype(np.float64)
                v = v.T  # MATLAB is column-major: HDF5 holds the transpose
                if cls == "char":
                    out[k] = "".join(chr(c) for c in v.reshape(-1, order="F"))
                elif v.dtype.kind in "biufc":
                    out[k] = v
    except OSError as exc:
        raise InputError(
            path,
            "file",
            f"cannot be read as a MATLAB v7.3 (HDF5) file ({_brief(exc)})",
            "a MATLAB v5 or v7.3 .mat file",
        ) from None
    return out


def _npz(path: Path) -> dict:
    try:
        with np.load(path, allow_pickle=False) as z:
            out = {}
            for k in z.files:
                v = z[k]
                if v.dtype.kind == "U" and v.size == 1:
                    out[k] = str(v.reshape(-1)[0])
                elif v.dtype.kind in "biufc":
                    out[k] = v
            return out
    except InputError:
        raise
    except Exception as exc:
        raise InputError(
            path, "file", f"cannot be read as a NumPy .npz archive ({_brief(exc)})", "an .npz written by numpy.savez"
        ) from None


def _from_named(path: Path, fmt: str, arrays: dict, *, variable=None, layout=None) -> Recording:
    """The I/Q, metadata and track from named arrays (a .mat or .npz)."""
    meta_names = {a: k for k, names in ALIASES.items() for a in names}
    md, fields, track = {}, {}, {}
    for name, v in arrays.items():
        key = meta_names.get(name.lower())
        if key is not None and (isinstance(v, str) or np.asarray(v).size == 1) and key not in md:
            md[key] = convert(key, v, path, name)
            fields[key] = name
        elif name.lower() in TRACK_VARS:
            track[name.lower()] = _real_vector(v, path, name).astype(np.float64)
    used = {fields[k] for k in fields} | {n for n in arrays if n.lower() in TRACK_VARS}
    candidates = [n for n, v in arrays.items() if n not in used and not isinstance(v, str) and np.asarray(v).size > 1]
    names_txt = ", ".join(sorted(candidates)) or "none"
    if variable:
        names = [s.strip() for s in str(variable).split(",")]
        for nm in names:
            if nm not in arrays or isinstance(arrays[nm], str):
                raise InputError(path, nm, "no such array", f"--variable one of: {names_txt}")
        if len(names) == 2:
            iq, found = iq_from_pair(arrays[names[0]], arrays[names[1]], path, tuple(names), layout), "iq-columns"
        elif len(names) == 1:
            iq, found = iq_from_array(arrays[names[0]], path, names[0], layout)
        else:
            raise InputError("--variable", "value", f"is {variable!r}", "NAME or NAME_I,NAME_Q")
        chosen = ",".join(names)
    else:
        lower = {n.lower(): n for n in candidates}
        if len(candidates) == 1:
            chosen = candidates[0]
            iq, found = iq_from_array(arrays[chosen], path, chosen, layout)
        elif "iq" in lower:
            chosen = lower["iq"]
            iq, found = iq_from_array(arrays[chosen], path, chosen, layout)
        elif {"i", "q"} <= set(lower) and len(candidates) == 2:
            names = (lower["i"], lower["q"])
            iq, found = iq_from_pair(arrays[names[0]], arrays[names[1]], path, names, layout), "iq-columns"
            chosen = ",".join(names)
        elif not candidates:
            raise InputError(path, "variables", "hold no I/Q array", SHAPE_EXPECTED)
        else:
            raise InputError(
                path,
                "variables",
                f"hold several arrays ({names_txt})",
                "--variable NAME (or NAME_I,NAME_Q) to pick the I/Q",
            )
    trk = None
    if track:
        if not {"track_time_s", "track_range_m"} <= set(track):
            have = next(iter(track))
            raise InputError(path, have, "given without track_time_s and track_range_m", "both arrays, or neither")
        trk = {
            "time_s": track["track_time_s"],
            "range_m": track["track_range_m"],
            "radial_velocity_mps": track.get("track_radial_velocity_mps"),
            "source": "file arrays track_*",
        }
    return Recording(
        path=path, format=fmt, layout=found, iq=iq, metadata=md, fields=fields, track=trk, info={"variable": chosen}
    )


def recording_from_arrays(
    path: Path, fmt: str, arrays: dict, *, variable: str | None = None, layout: str | None = None
) -> Recording:
    """A slow-time :class:`Recording` from :func:`read_arrays`' output."""
    if layout is not None and layout not in LAYOUTS:
        raise InputError("--layout", "value", f"is {layout!r}", " or ".join(LAYOUTS))
    if fmt == "npy":
        if variable:
            raise InputError(path, "--variable", "given for an .npy file", "no --variable (an .npy holds one array)")
        iq, found = iq_from_array(arrays["array"], path, "array", layout)
        return Recording(path=path, format="npy", layout=found, iq=iq)
    return _from_named(path, fmt, arrays, variable=variable, layout=layout)


def read_mat(path, *, variable: str | None = None, layout: str | None = None) -> Recording:
    """Read a MATLAB ``.mat`` recording (v5 via scipy, v7.3/HDF5 via h5py)."""
    import h5py

    path = Path(path)
    if h5py.is_hdf5(path):
        arrays, fmt = _mat_v73(path), "mat-v7.3"
    else:
        arrays, fmt = _mat_v5(path), "mat-v5"
    return _from_named(path, fmt, arrays, variable=variable, layout=layout)


def read_npz(path, *, variable: str | None = None, layout: str | None = None) -> Recording:
    """Read a NumPy ``.npz`` recording (named arrays, see the module docstring)."""
    path = Path(path)
    return _from_named(path, "npz", _npz(path), variable=variable, layout=layout)


def read_npy(path, *, layout: str | None = None) -> Recording:
    """Read a NumPy ``.npy`` recording: one complex vector or a real [n, 2] array."""
    path = Path(path)
    try:
        a = np.load(path, allow_pickle=False)
    except Exception as exc:
        raise InputError(
            path, "file", f"cannot be read as a NumPy .npy file ({_brief(exc)})", "an .npy written by numpy.save"
        ) from None
    iq, found = iq_from_array(a, path, "array", layout)
    return Recording(path=path, format="npy", layout=found, iq=iq)


def detect_format(path) -> str:
    name = Path(path).name.lower()
    if name.endswith((".sigmf-meta", ".sigmf-data")):
        return "sigmf"
    for fmt in ("mat", "npy", "npz"):
        if name.endswith("." + fmt):
            return fmt
    raise InputError(
        path, "file", "has an unknown suffix", "a .sigmf-meta/.sigmf-data pair, a .mat, an .npy or an .npz recording"
    )


def read_recording(path, *, variable: str | None = None, layout: str | None = None) -> Recording:
    """Read any supported recording, by suffix."""
    path = Path(path)
    fmt = detect_format(path)
    if layout is not None and layout not in LAYOUTS:
        raise InputError("--layout", "value", f"is {layout!r}", " or ".join(LAYOUTS))
    if fmt == "sigmf":
        if variable:
            raise InputError(
                path, "--variable", "given for a SigMF recording", "no --variable (SigMF holds one dataset)"
            )
        return read_sigmf(path, layout=layout)
    if not path.exists():
        raise InputError(path, "file", "does not exist", f"a .{fmt} recording")
    if path.is_dir():
        raise InputError(path, "file", "is a directory", f"a .{fmt} recording")
    if fmt == "mat":
        return read_mat(path, variable=variable, layout=layout)
    if fmt == "npz":
        return read_npz(path, variable=variable, layout=layout)
    if variable:
        raise InputError(path, "--variable", "given for an .npy file", "no --variable (an .npy holds one array)")
    return read_npy(path, layout=layout)


# ---- sidecar and parameters ------------------------------------------------------------


def read_sidecar(path) -> dict:
    """YAML sidecar -> ``{key: (value, label)}`` (keys of :data:`SIDECAR_KEYS`; a
    relative ``track`` path is relative to the sidecar)."""
    import yaml

    path = Path(path)
    if not path.is_file():
        raise InputError(
            path,
            "file",
            "does not exist" if not path.exists() else "is not a file",
            "a YAML sidecar with keys " + ", ".join(SIDECAR_KEYS),
        )
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise InputError(path, "yaml", f"cannot be parsed ({type(exc).__name__})", "a YAML mapping") from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise InputError(path, "yaml", f"is a {type(data).__name__}", "a YAML mapping of parameters")
    out = {}
    for k, v in data.items():
        if k not in SIDECAR_KEYS:
            raise InputError(path, str(k), "is not a sidecar key", ", ".join(SIDECAR_KEYS))
        if v is None:
            continue
        label = f"sidecar {path} key {k}"
        if k in PARAM_TYPES:
            v = convert(k, v, path, k)
        elif k == "track":
            v = Path(v) if Path(str(v)).is_absolute() else path.parent / str(v)
        elif k == "layout" and v not in LAYOUTS:
            raise InputError(path, k, f"is {v!r}", " or ".join(LAYOUTS))
        elif k == "noise_segment_s":
            v = parse_noise_segment(v, path, k)
        out[k] = (v, label)
    return out


def parse_noise_segment(value, source, where: str) -> tuple[float, float]:
    """``START:END`` (or ``[START, END]``) [s] -> ``(start, end)`` with ``0 <= start < end``."""
    parts = value if isinstance(value, (list, tuple)) else re.split(r"[:,]", str(value))
    try:
        a, b = (float(x) for x in parts)
    except (TypeError, ValueError):
        raise InputError(source, where, f"is {value!r}", "START:END in seconds, e.g. 0:2.5") from None
    if not (math.isfinite(a) and math.isfinite(b) and 0 <= a < b):
        raise InputError(source, where, f"is {value!r}", "START:END in seconds with 0 <= START < END")
    return a, b


def resolve_parameters(rec: Recording, options: dict, sidecar: dict) -> tuple[dict, dict, list[str]]:
    """Merge the file's metadata, a sidecar and options: option > sidecar > file.

    ``options`` and ``sidecar`` map a key to ``(value, label)``; a value that differs
    from the file's own metadata still wins, with a warning. Returns ``(params,
    sources, warnings)``; ``sources`` says where each parameter came from.
    """
    params, sources, warns = {}, {}, []
    for key in PARAM_TYPES:
        file_v = rec.metadata.get(key)
        file_label = f"file {rec.fields.get(key)}"
        for level in (options, sidecar):
            if key in level and level[key][0] is not None:
                v, label = level[key]
                if file_v is not None and not _same(v, file_v):
                    warns.append(f"{label} = {v!r} contradicts the file's {rec.fields[key]} = {file_v!r}; using {v!r}")
                params[key], sources[key] = v, label
                break
        else:
            if file_v is not None:
                params[key], sources[key] = file_v, file_label
    return params, sources, warns


def missing_parameter(rec: Recording, key: str) -> InputError:
    where = {"prf_hz": " (SigMF global core:sample_rate)", "carrier_hz": " (SigMF captures[0].core:frequency)"}
    hint = where.get(key, "") if rec.format == "sigmf" else ""
    return InputError(
        rec.path,
        key,
        f"missing{hint}: not in the file's metadata, a sidecar or the options",
        f"{OPTION[key]} or the sidecar key {key}",
    )


def check_required(rec: Recording, params: dict, *, track_missing: bool = False) -> None:
    """Raise one :class:`InputError` naming every required parameter that is missing
    (and the track, where ``track_missing`` and a parameter is missing too)."""
    need = REQUIRED + (DRONE_REQUIRED if params.get("target") == "drone" else ())
    missing = [key for key in need if key not in params]
    if len(missing) == 1 and not track_missing:
        raise missing_parameter(rec, missing[0])
    if missing:
        first = missing_parameter(rec, missing[0])
        opts = [OPTION[k] for k in missing] + (["--track CSV or --range-m"] if track_missing else [])
        raise InputError(
            rec.path,
            ", ".join(missing + (["track"] if track_missing else [])),
            f"missing{first.problem[len('missing') :]}",
            f"{', '.join(opts)} or the sidecar keys {', '.join(missing)}",
        )


# ---- tracks -----------------------------------------------------------------------------


def read_track(path) -> dict:
    """Track CSV (``time_s``, ``range_m``, optional ``radial_velocity_mps``), checked by
    :func:`microdoppler.io.tracks.read_track_table`; times are kept on the radar clock
    (not shifted to 0)."""
    import pandas as pd

    from .tracks import read_track_table

    path = Path(path)
    t, r = read_track_table(path)
    df = pd.read_csv(path)
    t0 = float(pd.to_numeric(df["time_s"]).iloc[0])
    out = {"time_s": (t - t[0]) + t0, "range_m": r, "radial_velocity_mps": None, "source": f"track {path}"}
    if "radial_velocity_mps" in df.columns:
        v = pd.to_numeric(df["radial_velocity_mps"], errors="coerce").to_numpy(np.float64)
        if not np.all(np.isfinite(v)):
            raise InputError(path, "radial_velocity_mps", "has non-numeric, NaN or infinite values", "finite numbers")
        out["radial_velocity_mps"] = v
    return out


def constant_track(range_m: float, duration_s: float, label: str) -> dict:
    """A staring / CW recording: constant range, radial velocity 0, over [0, duration]."""
    return {
        "time_s": np.array([0.0, duration_s]),
        "range_m": np.full(2, float(range_m)),
        "radial_velocity_mps": np.zeros(2),
        "source": label,
    }


def finish_track(trk: dict, source) -> dict:
    t = np.asarray(trk["time_s"], np.float64)
    r = np.asarray(trk["range_m"], np.float64)
    if len(t) != len(r):
        raise InputError(source, "track range_m", f"has {len(r)} rows", f"as many as time_s ({len(t)})")
    if len(t) < 2 or np.any(np.diff(t) <= 0) or not np.all(np.isfinite(t)):
        raise InputError(source, "track time_s", "is not strictly increasing with >= 2 rows", "increasing times [s]")
    if not np.all(np.isfinite(r)) or np.any(r <= 0):
        raise InputError(source, "track range_m", "has non-positive or non-finite ranges", "ranges > 0 m")
    v = trk.get("radial_velocity_mps")
    if v is None:
        v = np.gradient(r, t)
    v = np.asarray(v, np.float64)
    if len(v) != len(t) or not np.all(np.isfinite(v)):
        raise InputError(
            source, "track radial_velocity_mps", f"has {len(v)} rows or non-finite values", f"{len(t)} finite values"
        )
    return {"time_s": t, "range_m": r, "radial_velocity_mps": v, "source": trk.get("source", str(source))}


def _level_value(options: dict, sidecar: dict, key: str):
    """The option's value of ``key``, else the sidecar's, else None."""
    for lv in (options, sidecar):
        if lv.get(key, (None,))[0] is not None:
            return lv[key][0]
    return None


def explicit_track(options: dict, sidecar: dict, duration_s: float) -> dict | None:
    """The track that the options or the sidecar give (``track`` CSV or constant
    ``range_m``), options first; None if neither does."""
    for lv in (options, sidecar):
        if lv.get("track", (None,))[0] is not None:
            return read_track(lv["track"][0])
        if lv.get("range_m", (None,))[0] is not None:
            return constant_track(lv["range_m"][0], duration_s, f"constant range {lv['range_m'][1]}")
    return None


def explicit_track_given(options: dict, sidecar: dict) -> bool:
    """Whether the options or the sidecar give a track (``track`` or ``range_m``)."""
    return any(lv.get(k, (None,))[0] is not None for lv in (options, sidecar) for k in ("track", "range_m"))


def read_arrays(path: Path) -> tuple[str, dict]:
    """The named arrays of an ``.npy`` (one, named ``array``), ``.npz`` or ``.mat`` file,
    and its format (``npy``, ``npz``, ``mat-v5``, ``mat-v7.3``)."""
    import h5py

    fmt = detect_format(path)
    if not path.exists():
        raise InputError(path, "file", "does not exist", f"a .{fmt} recording")
    if path.is_dir():
        raise InputError(path, "file", "is a directory", f"a .{fmt} recording")
    if fmt == "mat":
        return ("mat-v7.3", _mat_v73(path)) if h5py.is_hdf5(path) else ("mat-v5", _mat_v5(path))
    if fmt == "npz":
        return "npz", _npz(path)
    try:
        return "npy", {"array": np.load(path, allow_pickle=False)}
    except Exception as exc:
        raise InputError(
            path, "file", f"cannot be read as a NumPy .npy file ({_brief(exc)})", "an .npy written by numpy.save"
        ) from None


def set_flight_id(rec, params: dict, sources: dict, default_flight_id: str | None) -> None:
    """``params["flight_id"]`` from the default (the output's or the file's name) when
    nothing gave one."""
    if "flight_id" not in params:
        fid = default_flight_id or default_flight_id_for(rec.path)
        params["flight_id"] = convert("flight_id", fid, rec.path, "flight_id (from the file name)")
        sources["flight_id"] = "default (file or output name)"


def default_flight_id_for(path) -> str:
    name = Path(path).name
    for ext in (".sigmf-meta", ".sigmf-data", ".zarr", ".mat", ".npz", ".npy"):
        if name.lower().endswith(ext):
            name = name[: -len(ext)]
            break
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name) or "flight"
