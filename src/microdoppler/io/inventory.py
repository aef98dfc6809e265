"""Inventory of measured flights and the ingest of their motor logs.

Works on any directory of flight-zarr/1 stores: nothing here depends on the
stores having come from the emulator. A flights table (TSV: flight_id, motor_log,
format, unit, time_offset_s) maps flights to external motor logs; a flight whose
store holds a log uses it when the table has no row; a drone flight with neither
is reported as ``skipped`` and left out of the synthetic twins (never guessed).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import zarr

from ..errors import InputError
from .flightzarr import validate_store
from .outputs import atomic_dir, commit_dir
from .motorlog import MotorLog, check_motor_log, read_motor_log

TABLE_COLUMNS = ("flight_id", "motor_log", "format", "unit", "time_offset_s")


def list_flights(measured_dir) -> pd.DataFrame:
    """Validate every ``*.zarr`` store in ``measured_dir``; one row per flight.

    Columns: flight_id, path, target, drone_model, radar_id, prf_hz, carrier_hz,
    n_pulses, duration_s, has_motor_log, has_background.
    """
    measured_dir = Path(measured_dir)
    if not measured_dir.is_dir():
        raise InputError(measured_dir, "directory", "does not exist", "a folder of <flight_id>.zarr stores")
    rows = []
    for p in sorted(measured_dir.glob("*.zarr")):
        f = validate_store(p)
        a = f.attrs
        rows.append(
            dict(
                flight_id=a["flight_id"],
                path=str(p),
                target=a["target"],
                drone_model=a.get("drone_model", ""),
                radar_id=a["radar_id"],
                prf_hz=float(a["prf_hz"]),
                carrier_hz=float(a["carrier_hz"]),
                n_pulses=len(f.iq),
                duration_s=len(f.iq) / float(a["prf_hz"]),
                has_motor_log=f.has_motor_log,
                has_background=f.background_iq is not None,
            )
        )
    if not rows:
        raise InputError(measured_dir, "directory", "holds no *.zarr stores", "flight-zarr/1 stores")
    df = pd.DataFrame(rows)
    dup = df.flight_id[df.flight_id.duplicated()]
    if len(dup):
        raise InputError(measured_dir, "attrs.flight_id", f"{dup.iloc[0]!r} appears twice", "unique flight ids")
    return df


#: the two classes of the bird/drone classifier
CLASSES = ("bird", "drone")


def flight_targets(measured_dir) -> dict[str, str]:
    """flight_id -> ``attrs.target`` of every ``*.zarr`` store in ``measured_dir``,
    read from the stores' attributes alone (cheap enough to call when a workflow is
    parsed; :func:`list_flights` validates the stores)."""
    out = {}
    for p in sorted(Path(measured_dir).glob("*.zarr")):
        a = dict(zarr.open_group(str(p), mode="r").attrs)
        out[str(a.get("flight_id", p.stem))] = str(a.get("target", ""))
    return out


def drone_models(measured_dir) -> list[str]:
    """The ``attrs.drone_model`` of the drone flights in ``measured_dir``, each once,
    sorted; read from the stores' attributes alone, like :func:`flight_targets`."""
    models = set()
    for p in sorted(Path(measured_dir).glob("*.zarr")):
        a = dict(zarr.open_group(str(p), mode="r").attrs)
        if a.get("target") == "drone" and a.get("drone_model"):
            models.add(str(a["drone_model"]))
    return sorted(models)


#: flights of each class a flight-disjoint train/test/validation split needs (one per set)
MIN_SPLIT_FLIGHTS = 3


def missing_class_note(
    measured_dir, targets: dict[str, str] | None = None, *, min_flights: int = MIN_SPLIT_FLIGHTS
) -> str:
    """Why the flights in ``measured_dir`` cannot train a bird/drone classifier, in
    one line, or ``""`` when they hold both classes with at least ``min_flights``
    flights each (one per set of the flight-disjoint train/test/validation split), or
    no store at all (the stages that read them say so)."""
    targets = flight_targets(measured_dir) if targets is None else targets
    counts = {c: sum(t == c for t in targets.values()) for c in CLASSES}
    if not targets:
        return ""
    held = ", ".join(f"{n} {c} flight{'s' if n != 1 else ''}" for c, n in counts.items() if n) or "no bird or drone"
    missing = [c for c in CLASSES if not counts[c]]
    if missing:
        return (
            f"classifier left out: the campaign in {measured_dir} has no {' or '.join(missing)} flights ({held}); "
            f"add {' and '.join(missing)} recordings to train a bird/drone classifier"
        )
    few = [c for c in CLASSES if counts[c] < min_flights]
    if few:
        return (
            f"classifier left out: the campaign in {measured_dir} has too few {' and '.join(few)} flights for a "
            f"flight-disjoint train/test/validation split ({held}; expected >= {min_flights} of each class, "
            f"one per set); add {' and '.join(few)} recordings"
        )
    return ""


def read_flights_table(path) -> pd.DataFrame:
    """Read the flights -> motor logs table (TSV); relative log paths are relative to the table."""
    path = Path(path)
    if not path.exists():
        raise InputError(path, "file", "does not exist", "a TSV with columns " + ", ".join(TABLE_COLUMNS))
    df = pd.read_csv(path, sep="\t", dtype={"flight_id": str})
    for c in ("flight_id", "motor_log"):
        if c not in df.columns:
            raise InputError(path, c, "column missing", "columns " + ", ".join(TABLE_COLUMNS))
    df["format"] = df.get("format", pd.Series([None] * len(df))).where(lambda s: s.notna(), None)
    df["unit"] = df.get("unit", pd.Series(["rpm"] * len(df))).fillna("rpm")
    df["time_offset_s"] = pd.to_numeric(df.get("time_offset_s", pd.Series([0.0] * len(df))), errors="coerce").fillna(
        0.0
    )
    df["motor_log"] = [str((path.parent / p).resolve()) if not Path(p).is_absolute() else p for p in df.motor_log]
    if df.flight_id.duplicated().any():
        raise InputError(
            path,
            "flight_id",
            f"{df.flight_id[df.flight_id.duplicated()].iloc[0]!r} appears twice",
            "one row per flight",
        )
    return df.set_index("flight_id")


#: prefix of a MotorLog's ``source`` when its speeds were estimated from the radar
RADAR_SOURCE = "radar:"


def ingest_flight_logs(measured_dir, out_zarr, out_csv, *, table_path=None, estimator=None, log=print) -> pd.DataFrame:
    """Ingest the motor log of every drone flight into one Zarr group per flight.

    Returns the status table (flight_id, status, source, rows, duration_s, n_motors,
    reason) and writes it to ``out_csv``. Status: ``ingested``, ``estimated`` (no log;
    with an ``estimator`` the rotor speeds were estimated from the flight's HERM
    lines; group attribute ``motors_source: radar``) or ``skipped`` (no log, and no
    estimate: ``reason`` says why).

    ``estimator`` (optional): called as ``estimator(flight, progress=...)`` on a drone
    flight without a motor log, it returns a rotor-speed estimate
    (:func:`microdoppler.rotors.speed.estimate_rotor_speeds`); None leaves such
    flights skipped.
    """
    flights = list_flights(measured_dir)
    table = read_flights_table(table_path) if table_path else None
    out_zarr = Path(out_zarr)
    tmp = atomic_dir(out_zarr)
    status = []
    try:
        root = zarr.open_group(str(tmp), mode="w", zarr_format=3)
        root.attrs.update({"schema": "motor-logs/1", "unit": "rev/min"})
        for fl in flights.itertuples():
            if fl.target != "drone":
                continue
            ml: MotorLog | None = None
            if table is not None and fl.flight_id in table.index:
                r = table.loc[fl.flight_id]
                opts = (
                    {"unit": r["unit"]} if (r["format"] or Path(r.motor_log).suffix.lower()) in ("csv", ".csv") else {}
                )
                ml = read_motor_log(r.motor_log, r["format"], **opts).shifted(float(r.time_offset_s))
                source = r.motor_log
            elif fl.has_motor_log:
                g = zarr.open_group(fl.path, mode="r")
                ml = check_motor_log(
                    fl.path,
                    g["motors/time_s"][...],
                    g["motors/rpm"][...],
                    unit="rpm",
                    time_field="motors/time_s",
                    speed_field="motors/rpm",
                )
                source = fl.path
            extra, state = {}, "ingested"
            if ml is None and estimator is not None:
                from .flightzarr import read_flight

                est = estimator(
                    read_flight(fl.path),
                    progress=lambda done, total, fid=fl.flight_id: log(
                        f"{fid}: rotor speeds from the radar: I/Q fit, {done} of {total} CPIs"
                    ),
                )
                if est.ok:
                    ml, source, state, extra = est.to_motor_log(), "radar", "estimated", est.store_attrs()
                else:
                    why = f"no motor log, and no estimate from the radar: {est.reason}"
            elif ml is None:
                why = "no motor log (neither in the store nor in the flights table)"
            if ml is None:
                log(f"{fl.flight_id}: {why}: skipped")
                status.append(
                    dict(
                        flight_id=fl.flight_id,
                        status="skipped",
                        source="",
                        rows=0,
                        duration_s=0.0,
                        n_motors=0,
                        reason=why,
                    )
                )
                continue
            g = root.require_group(fl.flight_id)
            g.attrs.update({"source": str(source), "drone_model": fl.drone_model, **extra})
            m = g.require_group("motors")
            m.create_array("time_s", data=ml.time_s.astype(np.float64))
            m.create_array("rpm", data=ml.rpm.astype(np.float32))
            status.append(
                dict(
                    flight_id=fl.flight_id,
                    status=state,
                    source=str(source),
                    rows=len(ml.time_s),
                    duration_s=ml.duration_s,
                    n_motors=ml.n_motors,
                    reason="",
                )
            )
            log(f"{fl.flight_id}: {len(ml.time_s)} rows, {ml.duration_s:.1f} s, {ml.n_motors} motors from {source}")
        commit_dir(tmp, out_zarr)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    df = pd.DataFrame(status, columns=["flight_id", "status", "source", "rows", "duration_s", "n_motors", "reason"])
    Path(out_csv).parent.mkdir(parents=True, exist_ok=True)
    df.to_csv(out_csv, index=False)
    return df


def read_ingested_log(logs_zarr, flight_id) -> MotorLog | None:
    """The ingested log of ``flight_id`` from ``results/motors/logs.zarr``, or None."""
    g = zarr.open_group(str(logs_zarr), mode="r")
    if flight_id not in g:
        return None
    t = np.asarray(g[f"{flight_id}/motors/time_s"][...])
    r = np.asarray(g[f"{flight_id}/motors/rpm"][...])
    radar = g[flight_id].attrs.get("motors_source") == "radar"
    return MotorLog(t, r, f"{RADAR_SOURCE if radar else ''}{logs_zarr}/{flight_id}")
