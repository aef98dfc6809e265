"""A campaign of one's own, end to end, on drone recordings from another radar (not in CI).

The acceptance run of docs/campaign.md: a folder of stand-mounted drone recordings
(body at 0 Hz, in the clutter notch) from the independent generator
``tests/independent_generator.py`` (no code shared with the emulator or the synthesis)
at its ``gen_s`` radar (2.9 GHz, PRF 9 kHz; the paper's is 1.35 GHz, 7.3 kHz), a
drone model the catalog does not hold, no motor logs (the pipeline estimates the rotor
speeds from the radar: ``measurements.estimate_missing_motor_logs``), and a weak blade
(``blade_imbalance``, drawn ``--imbalance-db`` low..high) on every other flight. The
pipeline's default target runs on it in a scratch folder, then:

- the run exits 0 and the classifier stage is left out with its one-line note (no birds);
  with ``--birds N`` (bird flights of the generator's own kind, :func:`make_bird`, at the
  same radar) the classifier runs instead and Table V has a row per training set with
  its flight-bootstrap intervals;
- no flight is skipped by the diagnosis for its length;
- no table under ``results/reports`` is empty (``fidelity_left_out.csv``, the flights
  left out, may be: then none is) and no figure is blank;
- Table VI has a row per variant;
- ``extended - sub_cpi`` on ``nonmultiple_db`` is resolved (its 95 % flight-bootstrap
  interval excludes 0) and negative (the extended twins are closer);
- per flight: the true imbalance, what the diagnosis named, the split's SNR line.

``--mode flying`` draws flying drones (a straight leg, 7-11 m/s scaled by the carrier)
instead of stand recordings. From the repository root (about 13 min on 2 shared cores;
the second, at a PRF of 2 kHz with 20-s flights; the third with birds trains
``--seeds`` classifiers per training set)::

    PYTHONPATH=src .venv/bin/python benchmarks/eval_campaign.py --seed 58 \\
        --workdir results/eval_campaign --json benchmarks/records/eval_campaign_58.json
    PYTHONPATH=src .venv/bin/python benchmarks/eval_campaign.py --seed 58 --mode flying \\
        --radar gen_2k --duration-s 20 --workdir results/eval_campaign_2k \\
        --json benchmarks/records/eval_campaign_58_flying_2k.json
    PYTHONPATH=src .venv/bin/python benchmarks/eval_campaign.py --seed 58 --birds 8 --seeds 3 \\
        --workdir results/eval_campaign_birds --json benchmarks/records/eval_campaign_58_birds.json

``--check-only`` re-reads an earlier run's folder (``run.json`` holds its truth and
exit status) without generating or running anything.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
from independent_generator import RADARS, GenCase, make_bird, make_flight  # noqa: E402

from microdoppler.io.flightzarr import write_flight  # noqa: E402
from microdoppler.io.outputs import atomic_file  # noqa: E402

VARIANTS = ["sub_cpi", "per_cpi", "single_motor", "fixed_speeds", "extended"]
NOTE = "classifier left out: the campaign in measured has no bird flights"


#: arguments that say where a run happened on its machine, not what it ran (left out of the record)
MACHINE_ARGS = ("workdir", "json", "snakemake")


def make_campaign(
    folder: Path,
    *,
    seed: int,
    n_flights: int,
    duration_s: float,
    radar: str,
    imbalance_db: tuple[float, float],
    mode: str = "stand",
    n_birds: int = 0,
) -> list[dict]:
    """Write ``n_flights`` drone recordings without motor logs (on a stand, or flying);
    every other one with a weak blade; then ``n_birds`` bird flights. Returns the
    truth per flight."""
    rng = np.random.default_rng([seed, 58])
    folder.mkdir(parents=True)
    truth = []
    for i in range(n_flights):
        weak = bool(i % 2)
        db = float(rng.uniform(*imbalance_db)) if weak else 0.0
        eff = {"blade_imbalance": {"imbalance_db": db}} if weak else {}
        fid = f"{mode}{i:02d}"
        speed = 0.0 if mode == "stand" else None  # None: the generator draws a flying leg
        flight, _ = make_flight(
            GenCase(
                fid, seed=int(rng.integers(1 << 30)), radar=radar, effects=eff, duration_s=duration_s, speed_mps=speed
            )
        )
        flight = dataclasses.replace(flight, motors_time_s=None, motors_rpm=None)  # speeds from the radar
        write_flight(folder / f"{fid}.zarr", flight)
        truth.append({"flight_id": fid, "target": "drone", "imbalance_db": db})
    for i in range(n_birds):
        fid = f"bird{i:02d}"
        flight, _ = make_bird(fid, seed=int(rng.integers(1 << 30)), radar=radar, duration_s=duration_s)
        write_flight(folder / f"{fid}.zarr", flight)
        truth.append({"flight_id": fid, "target": "bird", "imbalance_db": 0.0})
    return truth


def write_config(work: Path, *, n_boot: int, seeds: int) -> Path:
    cfg = yaml.safe_load((REPO / "config/config.yaml").read_text())
    cfg["classifier"]["seeds"] = list(range(1, seeds + 1))
    cfg["measurements"].update(source="directory", directory="measured", estimate_missing_motor_logs=True)
    cfg["figures"]["ulog"] = str((REPO / cfg["figures"]["ulog"]).resolve())
    cfg["fidelity"]["n_boot"] = int(n_boot)
    path = work / "config.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def blank_png(path: Path) -> bool:
    """True when the image holds a single colour (nothing drawn)."""
    import matplotlib.image as mpimg

    img = mpimg.imread(path)
    return bool(np.ptp(img[..., :3]) == 0) if img.ndim == 3 else bool(np.ptp(img) == 0)


def check(work: Path, rc: int, log: str, truth: list[dict]) -> dict:
    res = work / "results"
    reports = res / "reports"
    out: dict = {
        "exit_status": rc,
        "classifier_note_lines": log.count(NOTE),
        "table_v_written": (reports / "table_v.csv").exists(),
    }
    empty_tables, blank_figures = [], []
    for csv in sorted(reports.glob("*.csv")):
        if csv.name != "fidelity_left_out.csv" and len(pd.read_csv(csv)) == 0:
            empty_tables.append(csv.name)
    figures = sorted(list(res.glob("reports/*.png")) + list(res.glob("diagnosis/figures/*.png")))
    for png in figures:
        if png.stat().st_size == 0 or blank_png(png):
            blank_figures.append(str(png.relative_to(work)))
    out.update(empty_tables=empty_tables, blank_figures=blank_figures, n_figures=len(figures))
    if not (reports / "table_vi.csv").exists():
        out["table_vi"] = "missing"
        return out
    t6 = pd.read_csv(reports / "table_vi.csv")
    out["table_vi_variants"] = [v for v in t6.variant if " - " not in v]
    out["table_vi_row_per_variant"] = all(v in out["table_vi_variants"] for v in VARIANTS)
    cols = [
        "n_flights",
        "nonmultiple_db_mean",
        "nonmultiple_db_ci95_low",
        "nonmultiple_db_ci95_high",
        "nonmultiple_db_resolved",
    ]
    out["table_vi_nonmultiple_db"] = {
        r.variant: {
            c: (
                None
                if pd.isna(getattr(r, c))
                else (bool(getattr(r, c)) if c.endswith("resolved") else float(getattr(r, c)))
            )
            for c in cols
        }
        for r in t6.itertuples()
    }
    ext = t6[t6.variant == "extended - sub_cpi"]
    out["table_vi_extended_minus_sub_cpi"] = (
        {}
        if ext.empty
        else {
            c: (None if pd.isna(v) else (bool(v) if c.endswith("resolved") else float(v)))
            for c, v in ext.iloc[0].items()
            if c != "variant"
        }
    )
    gain = out["table_vi_nonmultiple_db"].get("extended - sub_cpi", {})
    out["nonmultiple_gain_resolved"] = bool(gain.get("nonmultiple_db_resolved"))
    out["nonmultiple_gain_negative"] = bool((gain.get("nonmultiple_db_mean") or 0) < 0)
    left = reports / "fidelity_left_out.csv"
    out["left_out"] = pd.read_csv(left).to_dict("records") if left.exists() else None
    # per flight: the truth, the diagnosis, the per-flight distances
    per = pd.read_csv(reports / "fidelity_flights.csv", dtype={"flight_id": str})
    report = json.loads((res / "diagnosis" / "report.json").read_text())
    named = {f["flight_id"]: f for f in report.get("flights", [])}
    split = pd.read_csv(res / "splits" / "flights.csv", dtype={"flight_id": str}).set_index("flight_id")
    rows = []
    for t in truth:
        fid = t["flight_id"]
        if t.get("target", "drone") != "drone":
            continue
        d = named.get(fid, {})
        causes = {c["cause"]: c.get("extension", {}).get("params", {}) for c in d.get("causes") or []}
        nm = per[per.flight_id == fid].set_index("variant")["nonmultiple_db"]
        row = {
            **t,
            "diagnosis": d.get("cause"),
            "reason": d.get("reason"),
            "named_imbalance_db": causes.get("blade_imbalance", {}).get("imbalance_db"),
            "other_causes": sorted(c for c in causes if c != "blade_imbalance"),
            "nonmultiple_dist_sub_cpi": float(nm.get("sub_cpi", np.nan)),
            "nonmultiple_dist_extended": float(nm.get("extended", np.nan)),
        }
        if fid in split.index:
            for c in ("set", "snr_db", "snr_line"):
                if c in split.columns:
                    v = split.loc[fid, c]
                    row[f"split_{c}"] = v.item() if hasattr(v, "item") else v
        rows.append(row)
    out["flights"] = rows
    out["skipped_for_length"] = [
        r["flight_id"] for r in rows if r["diagnosis"] == "skipped" and "too short" in str(r["reason"])
    ]
    t5 = reports / "table_v.csv"
    if t5.exists():
        tv = pd.read_csv(t5)
        out["table_v"] = tv[
            ["trainset", "n_seeds", "accuracy_mean", "accuracy_ci95_low", "accuracy_ci95_high"]
        ].to_dict("records")
    weak = [r for r in rows if r["imbalance_db"] > 0]
    out["weak_blade_named"] = sum(r["named_imbalance_db"] is not None for r in weak)
    out["weak_blade_false_alarms"] = sum(r["named_imbalance_db"] is not None for r in rows if r["imbalance_db"] == 0)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=58)
    ap.add_argument("--n-flights", type=int, default=12)
    ap.add_argument("--duration-s", type=float, default=16.0)
    ap.add_argument("--radar", choices=sorted(RADARS), default="gen_s")
    ap.add_argument("--imbalance-db", type=float, nargs=2, default=(4.0, 8.0), metavar=("LOW", "HIGH"))
    ap.add_argument("--n-boot", type=int, default=2000)
    ap.add_argument("--mode", choices=["stand", "flying"], default="stand", help="drones on a stand or flying")
    ap.add_argument("--birds", type=int, default=0, help="bird flights added (0: a drone-only campaign)")
    ap.add_argument("--seeds", type=int, default=9, help="classifier seeds per training set (with --birds)")
    ap.add_argument("--cores", type=int, default=2)
    ap.add_argument("--snakemake", default="", help="the snakemake executable (default: on PATH or beside python)")
    ap.add_argument("--workdir", required=True, help="scratch folder (must not exist)")
    ap.add_argument("--json", default="")
    ap.add_argument(
        "--check-only",
        action="store_true",
        help="re-read the results of an earlier run in --workdir (no generation, no pipeline)",
    )
    a = ap.parse_args(argv)
    if a.n_flights < 12:
        ap.error(f"--n-flights={a.n_flights}: the acceptance run needs at least 12 flights")
    work = Path(a.workdir)
    if a.check_only:
        if not (work / "run.json").exists():
            ap.error(f"--check-only: {work / 'run.json'} does not exist (run without --check-only first)")
        run = json.loads((work / "run.json").read_text())
    else:
        if work.exists():
            ap.error(f"--workdir {work} exists: give a new scratch folder")
        t0 = time.perf_counter()
        truth = make_campaign(
            work / "measured",
            seed=a.seed,
            n_flights=a.n_flights,
            duration_s=a.duration_s,
            radar=a.radar,
            imbalance_db=tuple(a.imbalance_db),
            mode=a.mode,
            n_birds=a.birds,
        )
        config = write_config(work, n_boot=a.n_boot, seeds=a.seeds)
        snakemake = a.snakemake or shutil.which("snakemake") or str(Path(sys.executable).with_name("snakemake"))
        t1 = time.perf_counter()
        r = subprocess.run(
            [
                sys.executable,
                snakemake,
                "--cores",
                str(a.cores),
                "-s",
                str(REPO / "Snakefile"),
                "-d",
                str(work),
                "--configfile",
                str(config),
            ],
            cwd=work,
            capture_output=True,
            text=True,
            env={**os.environ, "PYTHONPATH": os.environ.get("PYTHONPATH", str(REPO / "src"))},
        )
        t2 = time.perf_counter()
        (work / "snakemake.log").write_text(r.stdout + r.stderr)
        run = {
            "args": {k: v for k, v in vars(a).items() if k not in MACHINE_ARGS},
            "truth": truth,
            "exit_status": r.returncode,
            "generate_s": round(t1 - t0, 1),
            "pipeline_s": round(t2 - t1, 1),
        }
        (work / "run.json").write_text(json.dumps(run, indent=1))
    log = (work / "snakemake.log").read_text()
    rc = int(run["exit_status"])
    carrier, prf = RADARS[run["args"]["radar"]]
    out = {
        "seed": run["args"]["seed"],
        "args": run["args"],
        "carrier_hz": carrier,
        "prf_hz": prf,
        "generate_s": run["generate_s"],
        "pipeline_s": run["pipeline_s"],
        **check(work, rc, log, run["truth"]),
    }
    birds = sum(t.get("target") == "bird" for t in run["truth"])
    holds = {
        "exit_0": out["exit_status"] == 0,
        "none_skipped_for_length": not out.get("skipped_for_length"),
        "no_empty_table": not out["empty_tables"],
        "no_blank_figure": not out["blank_figures"],
        "table_vi_row_per_variant": out.get("table_vi_row_per_variant"),
        "nonmultiple_gain_resolved_and_negative": out.get("nonmultiple_gain_resolved", False)
        and out.get("nonmultiple_gain_negative", False),
    }
    if birds:
        rows5 = out.get("table_v", [])
        holds["table_v_row_per_trainset_with_intervals"] = all(
            any(r["trainset"] == v for r in rows5) for v in ["real", *VARIANTS]
        ) and all(np.isfinite([r["accuracy_ci95_low"], r["accuracy_ci95_high"]]).all() for r in rows5)
    else:
        holds["classifier_left_out_with_note"] = out["classifier_note_lines"] == 1 and not out["table_v_written"]
    out["acceptance"] = holds
    print(json.dumps(holds, indent=1))
    if rc != 0:
        print(log[-3000:], file=sys.stderr)
    if a.json:
        with atomic_file(a.json) as tmp:
            Path(tmp).write_text(json.dumps(out, indent=1, default=str) + "\n")
    return 0 if all(holds.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
