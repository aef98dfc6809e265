"""Pipeline entry points: diagnose the split's training drone flights, aggregate
their diagnosis into the ``extended`` variant's extensions."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from ..errors import InputError
from ..extensions import save_extensions
from .aggregate import aggregate
from .core import DiagnosisConfig, diagnose

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
    """Diagnose the drone flights of ``settings['sets']`` (default: train) with
    :func:`.core.diagnose`, using their ingested motor logs (or the stores' own);
    flights without a log are skipped (logged)."""
    from ..inventory import read_ingested_log

    pipe, cfg = split_settings(settings)
    Path(figures_dir).mkdir(parents=True, exist_ok=True)
    fids = list(_training_drones(split_csv, pipe["sets"])["flight_id"])
    logs = {}
    if Path(logs_zarr).exists():
        logs = {fid: ml for fid in fids if (ml := read_ingested_log(logs_zarr, fid)) is not None}
    return diagnose([Path(measured_dir) / f"{fid}.zarr" for fid in fids], out_json, motor_logs=logs, config=cfg,
                    figures_dir=figures_dir, log=log)


def aggregate_report(report_json, split_csv, out_yaml, *, settings=None):
    """extended.yaml from the report's flights in ``settings['sets']``."""
    pipe, _ = split_settings(settings)
    report = json.loads(Path(report_json).read_text())
    ids = set(_training_drones(split_csv, pipe["sets"])["flight_id"])
    ext = aggregate(report, min_fraction=pipe["min_fraction"], flight_ids=ids)
    save_extensions(ext, out_yaml)
    return ext
