"""Seed-to-seed spread of one training set under classifier settings (not in CI).

    python benchmarks/eval_seed_spread.py RESULTS_DIR --trainset fixed_speeds \\
        --config config/config.yaml --config config/paper.yaml \\
        --set augment='{"doppler_blur_bins": 3, "doppler_stretch": 0.1}' --seeds 1-9 --workers 2

Trains ``--trainset`` (the pipeline's recipe: ``microdoppler.datasets.load_trainset``
on RESULTS_DIR/tiles) once per seed with the classifier section of the merged
``--config`` files, overridden by ``--set KEY=JSON``, and tests every run on the
measured test tiles (RESULTS_DIR/tiles/real.zarr), as rules train_classifier and
evaluate_classifier do. Prints per seed accuracy, drone/bird recall, large-drone and
Mini accuracy, then mean +- std over seeds and the flight-bootstrap 95 % interval of
the seed-mean accuracy (``microdoppler.stats.bootstrap``). ``--json`` writes every number.
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

COLS = ("accuracy", "drone_recall", "bird_recall", "large_drone_accuracy", "small_drone_accuracy")


def classifier_config(configs: list[str], sets: list[str]) -> dict:
    cfg: dict = {}
    for path in configs:
        with open(path) as fh:
            cfg.update((yaml.safe_load(fh) or {}).get("classifier", {}) or {})
    for item in sets:
        key, _, value = item.partition("=")
        cfg[key] = json.loads(value)
    return cfg


def run_seed(args) -> tuple[int, pd.DataFrame, float]:
    tiles_dir, trainset, cfg_dict, seed = args
    from microdoppler.classifier import TrainConfig, load_trainset, predict, predictions_table, train

    t0 = time.process_time()
    cfg = TrainConfig.from_config(cfg_dict)
    tr, va, te = load_trainset(trainset, tiles_dir)
    res = train(tr, va, cfg, seed=seed, threads=1)
    table = predictions_table(te, predict(res.model, te.images, cfg.normalisation))
    return seed, table, time.process_time() - t0


def seeds_arg(text: str) -> list[int]:
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results", help="a pipeline results/ folder with tiles/")
    ap.add_argument("--trainset", default="real")
    ap.add_argument("--config", action="append", default=[], help="config file(s), merged in order")
    ap.add_argument("--set", action="append", default=[], help="classifier KEY=JSON override")
    ap.add_argument("--seeds", default="1-9")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--boot", type=int, default=2000)
    ap.add_argument("--json")
    ap.add_argument("--predictions", help="write every seed's test predictions (CSV)")
    a = ap.parse_args()

    from microdoppler.classifier import seed_metrics

    cfg = classifier_config(a.config or ["config/config.yaml"], a.set)
    tiles_dir = str(Path(a.results) / "tiles")
    seeds = seeds_arg(a.seeds)
    t0 = time.time()
    with ProcessPoolExecutor(a.workers) as ex:
        runs = sorted(ex.map(run_seed, [(tiles_dir, a.trainset, cfg, s) for s in seeds]), key=lambda r: r[0])
    rows = []
    for seed, table, cpu in runs:
        m = seed_metrics(table)
        rows.append({"seed": seed, **{c: 100 * m[c] for c in COLS}, "cpu_s": cpu})
        print(f"seed {seed}: " + "  ".join(f"{c} {100 * m[c]:.1f}" for c in COLS) + f"  ({cpu:.0f} CPU s)", flush=True)
    df = pd.DataFrame(rows)
    print(f"{a.trainset}, {len(seeds)} seeds, classifier overrides {a.set or 'none'} ({time.time() - t0:.0f} s wall)")
    for c in COLS:
        print(f"  {c}: {df[c].mean():.2f} +- {df[c].std(ddof=1):.2f}  (min {df[c].min():.1f}, max {df[c].max():.1f})")
    ci = flight_ci([r[1] for r in runs], a.boot)
    print(f"  accuracy, seed mean, 95 % flight-bootstrap CI: [{ci[0]:.2f}, {ci[1]:.2f}]")
    if a.predictions:
        pd.concat([t.assign(seed=s) for s, t, _ in runs]).to_csv(a.predictions, index=False)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump({"trainset": a.trainset, "classifier": cfg, "per_seed": rows, "accuracy_ci95": ci}, fh, indent=1)


def flight_ci(tables: list[pd.DataFrame], n_boot: int) -> tuple[float, float]:
    """95 % interval of the seed-mean accuracy: test flights drawn within their true
    class and seeds drawn, as in Table V (``microdoppler.stats.bootstrap``)."""
    from microdoppler.stats.bootstrap import draw_flights, interval, ratio_replicates

    flights = tables[0].groupby("flight_id", sort=True)["target"].first()
    draws = draw_flights(flights.index, strata=flights.to_numpy(), n_seeds=len(tables), n_boot=n_boot, seed=0)
    num = np.array(
        [
            (t["target"] == t["predicted"]).groupby(t["flight_id"]).sum().reindex(flights.index).to_numpy()
            for t in tables
        ],
        float,
    )
    den = tables[0].groupby("flight_id").size().reindex(flights.index).to_numpy(float)
    lo, hi = interval(ratio_replicates(num, den, draws))
    return 100 * lo, 100 * hi


if __name__ == "__main__":
    main()
