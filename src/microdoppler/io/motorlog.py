"""Motor-log ingest: PX4 ULog (``esc_status``, via pyulog) and CSV.

Output is the ``motors/time_s`` [s] and ``motors/rpm`` [rev/min] pair of
flight-zarr/1. Every check names the file, the field and what was expected.
"""

from __future__ import annotations

import os
import shutil
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import zarr

from ..errors import InputError
from .outputs import atomic_dir, commit_dir

#: conversion factors to rev/min
UNIT_TO_RPM = {"rpm": 1.0, "rev/s": 60.0, "rad/s": 60.0 / (2 * np.pi)}
TIME_UNIT_TO_S = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
#: plausible median flying speed of a drone rotor [rev/s] (paper §II: 40-250 Hz;
#: the PX4 fixture flies at 22-50 Hz) and the absolute ceiling
PLAUSIBLE_MEDIAN_REV_S = (10.0, 320.0)
MAX_REV_S = 600.0
MOTOR_STORE_SCHEMA = "motor-log/1"


@dataclass(frozen=True)
class MotorLog:
    """Logged motor speeds.

    Attributes
    ----------
    time_s : ndarray, float64 [n_log]
        Strictly increasing row times [s].
    rpm : ndarray, float32 [n_log, n_motors]
        Motor speeds [rev/min].
    source : str
        File it came from.

    See Also
    --------
    read_motor_log, microdoppler.rotors.resample

    Examples
    --------
    >>> import numpy as np
    >>> from microdoppler.io import MotorLog
    >>> log = MotorLog(np.array([0.0, 0.05, 0.1]), np.full((3, 4), 4800.0, np.float32))
    >>> log.n_motors, log.duration_s, float(log.rev_s[0, 0])
    (4, 0.1, 80.0)
    """

    time_s: np.ndarray
    rpm: np.ndarray
    source: str = ""

    @property
    def n_motors(self) -> int:
        return self.rpm.shape[1]

    @property
    def duration_s(self) -> float:
        return float(self.time_s[-1] - self.time_s[0])

    @property
    def rev_s(self) -> np.ndarray:
        return self.rpm.astype(np.float64) / 60.0

    def shifted(self, offset_s: float) -> "MotorLog":
        return MotorLog(self.time_s + offset_s, self.rpm, self.source)


def check_motor_log(
    source,
    time_s,
    rpm,
    *,
    unit: str = "rpm",
    time_field="time",
    speed_field="rpm",
    motor_names: list[str] | None = None,
    hint: str | None = None,
) -> MotorLog:
    """Validate arrays of a motor log and return a :class:`MotorLog` in rpm.

    ``motor_names`` (optional, one per column) name the motor in errors about a
    single motor (e.g. a NaN); default ``<speed_field>[motor j]``. ``hint`` replaces
    the advice given with an implausible median speed (default: check the declared
    unit), e.g. for speeds the radar itself estimated, where no unit was declared.
    """
    time_s = np.asarray(time_s, dtype=np.float64)
    speeds = np.asarray(rpm, dtype=np.float64)
    if time_s.size == 0:
        raise InputError(source, time_field, "has no rows", "at least 2 motor-log rows")
    if time_s.size < 2:
        raise InputError(source, time_field, "has 1 row", "at least 2 motor-log rows")
    if speeds.ndim != 2 or speeds.shape[0] != time_s.size or speeds.shape[1] < 1:
        raise InputError(source, speed_field, f"has shape {speeds.shape}", f"[{time_s.size}, n_motors]")
    if not np.all(np.isfinite(time_s)):
        i = int(np.flatnonzero(~np.isfinite(time_s))[0])
        raise InputError(source, time_field, f"row {i} is NaN or infinite", "finite times")
    bad = ~np.isfinite(speeds)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        name = motor_names[j] if motor_names is not None and j < len(motor_names) else f"{speed_field}[motor {j}]"
        raise InputError(source, name, f"row {i} is NaN or infinite", "finite speeds")
    d = np.diff(time_s)
    if np.any(d == 0):
        i = int(np.flatnonzero(d == 0)[0]) + 1
        raise InputError(source, time_field, f"row {i} repeats time {time_s[i]:g}", "strictly increasing times")
    if np.any(d < 0):
        i = int(np.flatnonzero(d < 0)[0]) + 1
        raise InputError(
            source,
            time_field,
            f"row {i} goes back in time ({time_s[i - 1]:g} -> {time_s[i]:g})",
            "strictly increasing times",
        )
    if unit not in UNIT_TO_RPM:
        raise InputError(source, "unit", f"is {unit!r}", " or ".join(UNIT_TO_RPM))
    rev_s = speeds * UNIT_TO_RPM[unit] / 60.0
    if np.any(rev_s < 0):
        raise InputError(source, speed_field, "has negative speeds", f"non-negative speeds in {unit}")
    flying = rev_s[rev_s > 0]
    if flying.size == 0:
        raise InputError(source, speed_field, "is zero everywhere", f"motor speeds in {unit}")
    med = float(np.median(flying))
    lo, hi = PLAUSIBLE_MEDIAN_REV_S
    if not (lo <= med <= hi) or rev_s.max() > MAX_REV_S:
        raise InputError(
            source,
            speed_field,
            f"median {np.median(speeds[speeds > 0]):.4g} {unit} = {med:.3g} rev/s is implausible for a drone rotor",
            f"a median of {lo:g}-{hi:g} rev/s; {hint or f'check the declared unit ({unit})'}",
        )
    return MotorLog(time_s, (rev_s * 60.0).astype(np.float32), str(source))


def _ulog_cut_at(path: Path) -> int | None:
    """Byte offset of a ULog message cut off by the end of the file, else None.

    ULog has no end marker; pyulog silently stops at a cut message. Walking the
    3-byte message headers (uint16 size, uint8 type) after the 16-byte file header
    tells whether the last message is complete.
    """
    data = path.read_bytes()
    pos, n = 16, len(data)
    if n < 16:
        return 0
    while pos + 3 <= n:
        size = int.from_bytes(data[pos : pos + 2], "little")
        if pos + 3 + size > n:
            return pos
        pos += 3 + size
    return pos if pos != n else None


def need_file(path, expected: str) -> Path:
    """``path`` as a Path if it is a readable regular file, else InputError."""
    path = Path(path)
    if not path.exists():
        raise InputError(path, "file", "does not exist", expected)
    if not path.is_file():
        raise InputError(path, "file", "is a directory" if path.is_dir() else "is not a regular file", expected)
    if not os.access(path, os.R_OK):
        raise InputError(path, "file", "cannot be read (permission denied)", expected)
    return path


def read_ulog(path, *, topic: str = "esc_status") -> MotorLog:
    """Read per-motor speeds from a PX4 ULog ``esc_status`` topic (``esc[i].esc_rpm``)."""
    from pyulog import ULog

    path = need_file(path, "a PX4 ULog file")
    if path.stat().st_size == 0:
        raise InputError(path, "file", "is empty", "a PX4 ULog file")
    with open(path, "rb") as fh:
        magic = fh.read(7)
    if magic != b"ULog\x01\x12\x35":
        raise InputError(path, "header", "has no ULog magic bytes", "a PX4 ULog file ('ULog' header)")
    cut = _ulog_cut_at(path)
    if cut is not None:
        raise InputError(
            path,
            "file",
            f"is truncated: the message at byte {cut} runs past the end of the file",
            "a complete PX4 ULog file",
        )
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ulog = ULog(str(path), [topic])
    except Exception as exc:
        raise InputError(
            path, "file", f"cannot be parsed ({type(exc).__name__}: {exc})", "a complete PX4 ULog file"
        ) from None
    if getattr(ulog, "file_corruption", False):
        raise InputError(
            path, "file", "is truncated or corrupt (pyulog reports file corruption)", "a complete PX4 ULog file"
        )
    try:
        ds = ulog.get_dataset(topic)
    except (IndexError, KeyError, ValueError):
        raise InputError(path, topic, "topic missing", f"a '{topic}' topic with esc[i].esc_rpm fields") from None
    data = ds.data
    n_esc = None
    if "esc_count" in data and len(data["esc_count"]):
        n_esc = int(np.max(data["esc_count"]))
    cols = []
    i = 0
    while f"esc[{i}].esc_rpm" in data:
        cols.append(f"esc[{i}].esc_rpm")
        i += 1
    if not cols:
        raise InputError(path, f"{topic}.esc[0].esc_rpm", "missing", "per-motor esc_rpm fields")
    if n_esc is not None:
        if n_esc < 1 or n_esc > len(cols):
            raise InputError(path, f"{topic}.esc_count", f"is {n_esc}", f"1-{len(cols)} motors")
        cols = cols[:n_esc]
    rpm = np.column_stack([data[c] for c in cols]).astype(np.float64)
    t_us = np.asarray(data["timestamp"], dtype=np.float64)
    if t_us.size == 0:
        raise InputError(path, f"{topic}.timestamp", "has no rows", "at least 2 rows")
    log = check_motor_log(
        path,
        (t_us - t_us[0]) * 1e-6,
        rpm,
        unit="rpm",
        time_field=f"{topic}.timestamp",
        speed_field=f"{topic}.esc_rpm",
        motor_names=[f"{topic}.{c}" for c in cols],
    )
    return log


def read_csv(
    path,
    *,
    unit: str = "rpm",
    time_column: str = "time_s",
    time_unit: str = "s",
    motor_columns: list[str] | None = None,
    n_motors: int | None = None,
) -> MotorLog:
    """Read a CSV motor log: one time column and one column per motor.

    Parameters
    ----------
    unit : {"rpm", "rev/s", "rad/s"}
        Unit of the motor columns.
    time_column, time_unit : str
        Name and unit (``s``, ``ms``, ``us``) of the time column.
    motor_columns : list of str, optional
        Motor columns; default: every other column.
    n_motors : int, optional
        Expected number of motors; a mismatch is an error.
    """
    path = need_file(path, "a CSV motor log")
    if path.stat().st_size == 0:
        raise InputError(path, "file", "is empty", "a CSV motor log with a header row")
    try:
        df = pd.read_csv(path)
    except Exception as exc:
        raise InputError(path, "file", f"cannot be parsed as CSV ({type(exc).__name__})", "a CSV motor log") from None
    if time_unit not in TIME_UNIT_TO_S:
        raise InputError(path, "time_unit", f"is {time_unit!r}", " or ".join(TIME_UNIT_TO_S))
    if time_column not in df.columns:
        raise InputError(path, time_column, "column missing", f"a time column '{time_column}' [{time_unit}]")
    if motor_columns is None:
        motor_columns = [c for c in df.columns if c != time_column]
    for c in motor_columns:
        if c not in df.columns:
            raise InputError(path, c, "motor column missing", f"columns {motor_columns}")
    if n_motors is not None and len(motor_columns) != n_motors:
        raise InputError(
            path,
            "motor columns",
            f"found {len(motor_columns)} ({', '.join(motor_columns)})",
            f"{n_motors} motor columns",
        )
    if not motor_columns:
        raise InputError(path, "motor columns", "none found", "one column per motor")
    try:
        t = pd.to_numeric(df[time_column], errors="raise").to_numpy(np.float64) * TIME_UNIT_TO_S[time_unit]
    except (ValueError, TypeError):
        raise InputError(path, time_column, "has non-numeric values", f"numbers [{time_unit}]") from None
    cols = []
    for c in motor_columns:
        try:
            cols.append(pd.to_numeric(df[c], errors="raise").to_numpy(np.float64))
        except (ValueError, TypeError):
            raise InputError(path, c, "has non-numeric values", f"numbers [{unit}]") from None
    return check_motor_log(
        path,
        t,
        np.column_stack(cols),
        unit=unit,
        time_field=time_column,
        speed_field=",".join(motor_columns) if len(motor_columns) < 2 else "motor columns",
        motor_names=list(motor_columns),
    )


def read_motor_log(path, fmt: str | None = None, **csv_options) -> MotorLog:
    """Read a motor log (PX4 ULog or CSV).

    Parameters
    ----------
    path : str or path-like
        The log file.
    fmt : {"ulog", "csv"}, optional
        Its format; default from the suffix (``.ulg``, ``.csv``).
    **csv_options
        For CSV: ``unit`` (``rpm``, ``rev/s`` or ``rad/s``), ``time_column``,
        ``time_unit`` (``s``, ``ms``, ``us``), ``motor_columns``.

    Returns
    -------
    MotorLog
        Row times [s] and speeds [rev/min].

    Raises
    ------
    microdoppler.errors.InputError
        Naming the file, the field and what was expected (an unknown suffix, a
        missing column, non-increasing times, implausible speeds, ...).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from microdoppler.io import read_motor_log
    >>> path = Path(tempfile.mkdtemp()) / "log.csv"
    >>> _ = path.write_text("time_s,m1,m2\\n0,4800,4810\\n0.05,4820,4790\\n0.1,4830,4800\\n")
    >>> log = read_motor_log(path)
    >>> log.n_motors, log.rpm.dtype, log.rpm[-1].tolist()
    (2, dtype('float32'), [4830.0, 4800.0])
    """
    path = Path(path)
    if fmt is None:
        fmt = {".ulg": "ulog", ".csv": "csv"}.get(path.suffix.lower())
        if fmt is None:
            raise InputError(
                path, "format", f"unknown suffix {path.suffix!r}", "'.ulg' (PX4 ULog) or '.csv', or an explicit format"
            )
    if fmt == "ulog":
        return read_ulog(path)
    if fmt == "csv":
        return read_csv(path, **csv_options)
    raise InputError(path, "format", f"is {fmt!r}", "'ulog' or 'csv'")


def write_motor_store(path, log: MotorLog, attrs: dict | None = None) -> Path:
    """Write ``motors/time_s`` and ``motors/rpm`` to a Zarr group, atomically."""
    path = Path(path)
    tmp = atomic_dir(path)
    try:
        g = zarr.open_group(str(tmp), mode="w", zarr_format=3)
        g.attrs.update({"schema": MOTOR_STORE_SCHEMA, "source": log.source, "unit": "rev/min", **(attrs or {})})
        m = g.require_group("motors")
        m.create_array("time_s", data=log.time_s.astype(np.float64))
        m.create_array("rpm", data=log.rpm.astype(np.float32))
        commit_dir(tmp, path)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return path


def read_motor_store(path) -> MotorLog:
    """Read a store written by :func:`write_motor_store` or a flight store's motor log."""
    path = Path(path)
    try:
        g = zarr.open_group(str(path), mode="r")
        t = np.asarray(g["motors/time_s"][...])
        r = np.asarray(g["motors/rpm"][...])
    except Exception:
        raise InputError(path, "motors", "missing or unreadable", "motors/time_s and motors/rpm arrays") from None
    return check_motor_log(path, t, r, unit="rpm", time_field="motors/time_s", speed_field="motors/rpm")
