"""Pipeline entry points: diagnose the split's training drone flights, aggregate
their diagnosis into the ``extended`` variant's extensions."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from ..errors import InputError
from ..extensions import save_extensions
from ..flightzarr import read_flight
from .aggregate import aggregate
from .core import DiagnosisConfig, diagnose_flight, write_json
from ..catalog import CATALOG

#: keys of the ``diagnosis:`` config section that are pipeline settings, not
#: :class:`DiagnosisConfig` fields
PIPELINE_KEYS = ("sets", "min_fraction")


def split_settings(settings: dict | None) -> tuple[dict, DiagnosisConfig]:
    s = dict(settings or {})
    pipe = {"sets": list(s.pop("sets", ["train"])), "min_fraction": float(s.pop("min_fraction", 0.25))}
    return pipe, DiagnosisConfig.from_dict(s)


def _training_drones(split_csv, sets) -> pd.DataFrame:
    df = pd.read_csv(split_csv)
    for col in ("flight_id", "set", "target"):
        if col not in df.columns:
            raise InputError(split_csv, col, "column missing", "flight_id, set, target columns")
    return df[(df["target"] == "drone") & df["set"].isin(sets)]


def diagnose_split(measured_dir, logs_zarr, split_csv, out_json, figures_dir, *, settings=None, log=print) -> dict:
    """Diagnose the drone flights of ``settings['sets']`` (default: train) that have an
    ingested motor log; skipped flights are logged."""
    from ..inventory import read_ingested_log

    pipe, cfg = split_settings(settings)
    Path(figures_dir).mkdir(parents=True, exist_ok=True)
    entries = []
    for fid in _training_drones(split_csv, pipe["sets"])["flight_id"]:
        path = Path(measured_dir) / f"{fid}.zarr"
        ml = read_ingested_log(logs_zarr, fid) if Path(logs_zarr).exists() else None
        flight = read_flight(path)
        if ml is None and not flight.has_motor_log:
            log(f"skip {fid}: no motor log")
            continue
        e = diagnose_flight(flight, motor_log=ml, config=cfg, figure_path=Path(figures_dir) / f"{fid}.png")
        log(f"{fid}: {e['cause']} {e['extension']['params'] if e['extension'] else ''} "
            f"({e['evidence']['seconds']:.1f} s for {flight.duration_s:.0f} s)")
        entries.append(e)
    report = {"catalog": list(CATALOG), "flights": entries}
    write_json(report, out_json)
    return report


def aggregate_report(report_json, split_csv, out_yaml, *, settings=None):
    """extended.yaml from the report's flights in ``settings['sets']``."""
    pipe, _ = split_settings(settings)
    report = json.loads(Path(report_json).read_text())
    ids = set(_training_drones(split_csv, pipe["sets"])["flight_id"])
    ext = aggregate(report, min_fraction=pipe["min_fraction"], flight_ids=ids)
    save_extensions(ext, out_yaml)
    return ext
