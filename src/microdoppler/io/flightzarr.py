"""The flight-zarr/1 exchange format (its definition: the documentation's page ``docs/format.md``).

One measured flight is one Zarr group. :func:`read_flight` validates a store and
returns a :class:`Flight`; :func:`write_flight` writes one atomically (to a sibling
temporary directory, then renamed), so an interrupted write never leaves a
half-written store under the final name.
"""

from __future__ import annotations

import re
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import zarr

from ..errors import InputError
from .outputs import atomic_dir, commit_dir

SCHEMA = "flight-zarr/1"
TARGETS = ("drone", "bird", "none")
FLIGHT_ID_RE = re.compile(r"^[A-Za-z0-9_.-]+$")

#: path -> (dtype, ndim); ``None`` ndim means "checked separately"
ARRAYS = {
    "iq": (np.complex64, 1),
    "track/time_s": (np.float64, 1),
    "track/range_m": (np.float64, 1),
    "track/radial_velocity_mps": (np.float64, 1),
    "motors/time_s": (np.float64, 1),
    "motors/rpm": (np.float32, 2),
    "background/iq": (np.complex64, 1),
}
REQUIRED = ("iq", "track/time_s", "track/range_m", "track/radial_velocity_mps")
DRONE_ATTRS = {"drone_model": str, "n_motors": int, "n_blades": int, "blade_length_m": float}


@dataclass
class Flight:
    """One flight in memory.

    Attributes
    ----------
    attrs : dict
        Group attributes (``schema``, ``flight_id``, ``target``, ``radar_id``,
        ``prf_hz``, ``carrier_hz`` and, for drones, the rotor geometry). Unknown
        attributes are preserved.
    iq : ndarray, complex64 [n_pulses]
        Slow-time samples, one per pulse (pulse i at i / ``prf_hz`` s).
    track_time_s, track_range_m, track_radial_velocity_mps : ndarray, float64 [n_track]
        The tracker's output: time [s], range [m], radial velocity [m/s], positive
        receding.
    motors_time_s : ndarray, float64 [n_log] or None
        Motor-log row times [s], on the radar clock.
    motors_rpm : ndarray, float32 [n_log, n_motors] or None
        Logged motor speeds [rev/min].
    background_iq : ndarray, complex64 [n_pulses] or None
        A target-free recording of the same cells.
    extra_arrays : dict
        Further arrays of the store, written back unchanged.

    See Also
    --------
    read_flight, write_flight, microdoppler.emulator.emulate_flight

    Examples
    --------
    >>> from microdoppler.emulator import FlightSpec, emulate_flight
    >>> flight, truth = emulate_flight(FlightSpec("demo", "drone", drone_model="inspire2", duration_s=1.0, seed=1))
    >>> flight.iq.dtype, flight.iq.shape, flight.prf_hz
    (dtype('complex64'), (7300,), 7300.0)
    >>> round(flight.wavelength_m, 3), flight.duration_s, flight.has_motor_log
    (0.222, 1.0, True)
    """

    attrs: dict
    iq: np.ndarray
    track_time_s: np.ndarray
    track_range_m: np.ndarray
    track_radial_velocity_mps: np.ndarray
    motors_time_s: np.ndarray | None = None
    motors_rpm: np.ndarray | None = None
    background_iq: np.ndarray | None = None
    extra_arrays: dict = field(default_factory=dict)

    @property
    def flight_id(self) -> str:
        return self.attrs["flight_id"]

    @property
    def prf_hz(self) -> float:
        return float(self.attrs["prf_hz"])

    @property
    def carrier_hz(self) -> float:
        return float(self.attrs["carrier_hz"])

    @property
    def wavelength_m(self) -> float:
        return 299_792_458.0 / self.carrier_hz

    @property
    def duration_s(self) -> float:
        return len(self.iq) / self.prf_hz

    @property
    def has_motor_log(self) -> bool:
        return self.motors_time_s is not None and self.motors_rpm is not None

    def arrays(self) -> dict:
        out = {
            "iq": self.iq,
            "track/time_s": self.track_time_s,
            "track/range_m": self.track_range_m,
            "track/radial_velocity_mps": self.track_radial_velocity_mps,
        }
        if self.motors_time_s is not None:
            out["motors/time_s"] = self.motors_time_s
        if self.motors_rpm is not None:
            out["motors/rpm"] = self.motors_rpm
        if self.background_iq is not None:
            out["background/iq"] = self.background_iq
        out.update(self.extra_arrays)
        return out


def _check_attrs(store, attrs: dict) -> None:
    def need(name, typ, expected):
        if name not in attrs:
            raise InputError(store, f"attrs.{name}", "missing", expected)
        val = attrs[name]
        ok = isinstance(val, typ) and not (typ in (int, float) and isinstance(val, bool))
        if typ is float and isinstance(val, int) and not isinstance(val, bool):
            ok = True
        if not ok:
            raise InputError(store, f"attrs.{name}", f"has type {type(val).__name__}", expected)
        return val

    schema = attrs.get("schema")
    if schema != SCHEMA:
        raise InputError(store, "attrs.schema", f"is {schema!r}", repr(SCHEMA))
    fid = need("flight_id", str, "a string")
    if not FLIGHT_ID_RE.match(fid):
        raise InputError(store, "attrs.flight_id", f"is {fid!r}", "[A-Za-z0-9_.-]+")
    target = need("target", str, "a string")
    if target not in TARGETS:
        raise InputError(store, "attrs.target", f"is {target!r}", " or ".join(TARGETS))
    need("radar_id", str, "a string")
    for name in ("prf_hz", "carrier_hz"):
        v = need(name, float, "a positive number [Hz]")
        if not (np.isfinite(v) and v > 0):
            raise InputError(store, f"attrs.{name}", f"is {v}", "a positive number [Hz]")
    if target == "drone":
        for name, typ in DRONE_ATTRS.items():
            v = need(name, typ, f"a {typ.__name__}")
            if typ is not str and not v > 0:
                raise InputError(store, f"attrs.{name}", f"is {v}", "> 0")


def _check_array(store, path, arr: np.ndarray) -> None:
    dtype, ndim = ARRAYS[path]
    if arr.dtype != dtype:
        raise InputError(store, path, f"has dtype {arr.dtype}", np.dtype(dtype).name)
    if arr.ndim != ndim:
        raise InputError(store, path, f"has {arr.ndim} dimensions", f"{ndim}")
    if not np.all(np.isfinite(arr)):
        raise InputError(store, path, "contains NaN or infinite values", "finite values")


def _check_consistency(store, attrs, arrs: dict) -> None:
    n = len(arrs["iq"])
    if n == 0:
        raise InputError(store, "iq", "is empty", "at least one pulse")
    t = arrs["track/time_s"]
    for p in ("track/range_m", "track/radial_velocity_mps"):
        if len(arrs[p]) != len(t):
            raise InputError(store, p, f"has length {len(arrs[p])}", f"length of track/time_s ({len(t)})")
    if len(t) < 2:
        raise InputError(store, "track/time_s", f"has {len(t)} rows", "at least 2")
    if np.any(np.diff(t) <= 0):
        raise InputError(store, "track/time_s", "is not strictly increasing", "increasing times [s]")
    if np.any(arrs["track/range_m"] <= 0):
        raise InputError(store, "track/range_m", "has non-positive ranges", "ranges > 0 m")
    has_t, has_r = "motors/time_s" in arrs, "motors/rpm" in arrs
    if has_t != has_r:
        missing = "motors/rpm" if has_t else "motors/time_s"
        raise InputError(store, missing, "missing while its partner is present", "both motors arrays or neither")
    if has_t:
        mt, mr = arrs["motors/time_s"], arrs["motors/rpm"]
        if attrs.get("target") != "drone":
            raise InputError(store, "motors", "present on a non-drone flight", "motor logs only for drones")
        if len(mt) < 2 or np.any(np.diff(mt) <= 0):
            raise InputError(store, "motors/time_s", "is not strictly increasing", "increasing times [s], >= 2 rows")
        if mr.shape[0] != len(mt):
            raise InputError(store, "motors/rpm", f"has {mr.shape[0]} rows", f"{len(mt)} rows (motors/time_s)")
        if mr.shape[1] != attrs.get("n_motors"):
            raise InputError(store, "motors/rpm", f"has {mr.shape[1]} columns", f"n_motors={attrs.get('n_motors')}")
        if np.any(mr < 0) or np.any(mr > 60000):
            raise InputError(store, "motors/rpm", "has speeds outside 0-60000", "rev/min")
    if "background/iq" in arrs and len(arrs["background/iq"]) != n:
        raise InputError(store, "background/iq", f"has length {len(arrs['background/iq'])}", f"len(iq)={n}")


def _chunks_present(store, p: str, node) -> None:
    """Every chunk of ``node`` is stored (a missing chunk reads back as zeros)."""
    try:
        have, need = node.nchunks_initialized, node.nchunks
    except Exception as exc:  # listing a broken store
        raise InputError(store, p, f"chunks cannot be listed ({type(exc).__name__})", "a readable store") from None
    if have < need:
        raise InputError(
            store,
            p,
            f"has {need - have} of {need} chunk files missing (they would read back as zeros)",
            "every chunk stored",
        )


def _read(store, p: str, node, sel=Ellipsis) -> np.ndarray:
    """``node[sel]``; an unreadable (truncated, corrupt) chunk raises InputError."""
    try:
        return np.asarray(node[sel])
    except Exception as exc:
        where = f" in samples {sel.start}-{sel.stop - 1}" if isinstance(sel, slice) else ""
        raise InputError(
            store,
            p,
            f"cannot be read{where} ({type(exc).__name__}: {str(exc)[:80]})",
            "complete, uncorrupted chunk files",
        ) from None


def _stream_finite(store, p: str, node) -> None:
    """Check ``node`` for NaN/inf chunk by chunk (memory: one chunk)."""
    step = int(node.chunks[0]) if node.ndim else 1
    for start in range(0, node.shape[0], step):
        block = _read(store, p, node, slice(start, min(start + step, node.shape[0])))
        if not np.all(np.isfinite(block)):
            k = start + int(np.flatnonzero(~np.isfinite(block.reshape(len(block), -1)).any(axis=1))[0])
            raise InputError(store, p, f"contains NaN or infinite values (first at sample {k})", "finite values")


def read_flight(path, *, load_iq: bool = True, content: bool = True) -> Flight:
    """Open, validate and load a flight-zarr/1 store.

    Parameters
    ----------
    path : str or path-like
        The store (a Zarr group directory, conventionally ``<flight_id>.zarr``).
    load_iq : bool
        Load ``iq`` and ``background/iq`` (else zero-filled placeholders of the right
        shape are returned).
    content : bool
        Check that every chunk is stored and readable and every value finite; without
        ``load_iq`` the I/Q arrays are streamed chunk by chunk. ``False`` checks the
        metadata (attributes, dtypes, shapes) and the small track/motor arrays only.

    Returns
    -------
    Flight
        The flight in memory.

    Raises
    ------
    microdoppler.errors.InputError
        Naming the store, the field and what was expected (a missing store, a
        missing attribute or array, a wrong dtype, NaN values, ...).

    See Also
    --------
    write_flight, validate_store, microdoppler.importing.import_recording

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from microdoppler.emulator import FlightSpec, emulate_flight
    >>> from microdoppler.io import read_flight, write_flight
    >>> flight, _ = emulate_flight(FlightSpec("demo", "drone", drone_model="inspire2", duration_s=1.0, seed=1))
    >>> path = write_flight(Path(tempfile.mkdtemp()) / "demo.zarr", flight)
    >>> again = read_flight(path)
    >>> again.flight_id, again.attrs["n_blades"], bool((again.iq == flight.iq).all())
    ('demo', 2, True)
    >>> read_flight(path.parent / "missing.zarr")
    Traceback (most recent call last):
    ...
    microdoppler.errors.InputError: .../missing.zarr: store: does not exist (expected a flight-zarr/1 directory)
    """
    path = Path(path)
    if not path.exists():
        raise InputError(path, "store", "does not exist", "a flight-zarr/1 directory")
    if not path.is_dir():
        raise InputError(path, "store", "is a file", "a flight-zarr/1 directory (Zarr group)")
    try:
        g = zarr.open_group(str(path), mode="r")
        attrs = dict(g.attrs)
    except Exception as exc:  # zarr raises several types for non-stores
        raise InputError(
            path, "store", f"is not a Zarr group ({type(exc).__name__})", "a flight-zarr/1 group"
        ) from None
    _check_attrs(path, attrs)
    arrs = {}
    for p, (dtype, ndim) in ARRAYS.items():
        try:
            node = g[p]
        except KeyError:
            if p in REQUIRED:
                raise InputError(path, p, "missing", f"{np.dtype(dtype).name} array") from None
            continue
        except Exception as exc:
            raise InputError(path, p, f"metadata unreadable ({type(exc).__name__})", "a Zarr array") from None
        if not isinstance(node, zarr.Array):
            raise InputError(path, p, "is a group", "an array")
        if node.dtype != dtype:
            raise InputError(path, p, f"has dtype {node.dtype}", np.dtype(dtype).name)
        if node.ndim != ndim:
            raise InputError(path, p, f"has {node.ndim} dimensions {tuple(node.shape)}", f"{ndim}")
        if content:
            _chunks_present(path, p, node)
        if p in ("iq", "background/iq") and not load_iq:
            if content:
                _stream_finite(path, p, node)
            arrs[p] = np.zeros(node.shape, node.dtype)
            continue
        arrs[p] = _read(path, p, node)
        _check_array(path, p, arrs[p])
    _check_consistency(path, attrs, arrs)
    return Flight(
        attrs=attrs,
        iq=arrs["iq"],
        track_time_s=arrs["track/time_s"],
        track_range_m=arrs["track/range_m"],
        track_radial_velocity_mps=arrs["track/radial_velocity_mps"],
        motors_time_s=arrs.get("motors/time_s"),
        motors_rpm=arrs.get("motors/rpm"),
        background_iq=arrs.get("background/iq"),
    )


def validate_store(path, *, quick: bool = False) -> Flight:
    """Validate a store; returns the flight without I/Q.

    By default the content is checked too (every chunk present and readable, every
    value finite), streamed chunk by chunk so a long flight stays within memory;
    ``quick`` checks the metadata only.

    Parameters
    ----------
    path : str or path-like
        The flight-zarr/1 store.
    quick : bool
        Check the metadata (attributes, dtypes, shapes) only.

    Returns
    -------
    Flight
        The flight with zero-filled ``iq`` and ``background_iq`` of the stored shape.

    Raises
    ------
    microdoppler.errors.InputError
        Naming the store, the field and what was expected.

    See Also
    --------
    read_flight

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from microdoppler.emulator import FlightSpec, emulate_flight
    >>> from microdoppler.io import validate_store, write_flight
    >>> flight, _ = emulate_flight(FlightSpec("demo", "drone", drone_model="inspire2", duration_s=1.0, seed=1))
    >>> path = write_flight(Path(tempfile.mkdtemp()) / "demo.zarr", flight)
    >>> validate_store(path).iq.shape
    (7300,)
    """
    return read_flight(path, load_iq=False, content=not quick)


def write_flight(path, flight: Flight, *, chunk_pulses: int = 1 << 18) -> Path:
    """Write ``flight`` as a flight-zarr/1 store, atomically. Validates first.

    Parameters
    ----------
    path : str or path-like
        The store to write (a directory); replaced atomically if it exists.
    flight : Flight
        The flight; its arrays are cast to the format's dtypes.
    chunk_pulses : int
        Chunk length of the pulse-rate arrays [pulses].

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    microdoppler.errors.InputError
        When the flight breaks the format (a missing attribute, NaN values, a track
        that does not cover the flight, ...); nothing is written then.

    See Also
    --------
    read_flight, Flight

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from microdoppler.emulator import FlightSpec, emulate_flight
    >>> from microdoppler.io import write_flight
    >>> flight, _ = emulate_flight(FlightSpec("demo", "drone", drone_model="inspire2", duration_s=1.0, seed=1))
    >>> write_flight(Path(tempfile.mkdtemp()) / "demo.zarr", flight).name
    'demo.zarr'
    """
    path = Path(path)
    attrs = dict(flight.attrs)
    attrs.setdefault("schema", SCHEMA)
    arrs = {p: np.asarray(a) for p, a in flight.arrays().items()}
    for p, a in arrs.items():
        if p in ARRAYS:
            dt = ARRAYS[p][0]
            arrs[p] = a.astype(dt, copy=False)
            _check_array(path, p, arrs[p])
    _check_attrs(path, attrs)
    _check_consistency(path, attrs, arrs)
    tmp = atomic_dir(path)
    try:
        g = zarr.open_group(str(tmp), mode="w", zarr_format=3)
        g.attrs.update(attrs)
        for p, a in arrs.items():
            chunks = (min(chunk_pulses, max(1, a.shape[0])),) + a.shape[1:]
            z = g.create_array(p, shape=a.shape, dtype=a.dtype, chunks=chunks, config={"write_empty_chunks": True})
            z[...] = a
        commit_dir(tmp, path)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return path
