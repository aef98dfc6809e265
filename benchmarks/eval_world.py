"""The emulated world against the paper's Table III: SNR per class, and its spread.

    .venv/bin/python benchmarks/eval_world.py [--per-class 30] [--profile paper] [--seed 0]

Draws ``--per-class`` flights of each class (bird, Inspire, Matrice, Mini) at random
(seed ``--seed``) from the world plan of ``--profile``, emulates them (no background
recording; full duration, or at most ``--max-duration-s``) and measures each flight's
body SNR per timestep with the pipeline's one SNR measure
(``microdoppler.spectra.snr.flight_body_snr_db``). Per class: the mean SNR over flights and the
mean over flights of the per-flight std ("mean STD of each flight" in Table III), each
with a 95 % bootstrap interval over flights (``microdoppler.stats.bootstrap``), beside Table
III's training-set values.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np
import pandas as pd

from microdoppler.stats.bootstrap import draw_flights, interval
from microdoppler.emulator.profiles import plan_world
from microdoppler.emulator.world import emulate_flight
from microdoppler.spectra.snr import flight_body_snr_db

#: Table III, training set: mean SNR and mean per-flight std [dB]
TABLE_III = {"bird": (29.0, 5.5), "inspire2": (39.0, 7.0), "matrice300": (41.0, 7.5), "mini2": (34.0, 5.7)}


def main(argv=None) -> pd.DataFrame:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--per-class", type=int, default=30)
    ap.add_argument("--profile", default="paper")
    ap.add_argument("--seed", type=int, default=0, help="world seed")
    ap.add_argument("--draw-seed", type=int, default=5, help="seed of the flights drawn from the plan")
    ap.add_argument("--max-duration-s", type=float, default=None)
    ap.add_argument("--classes", default=",".join(TABLE_III), help="comma-separated classes")
    ap.add_argument("--csv", default=None, help="write the per-flight rows here")
    args = ap.parse_args(argv)
    specs = plan_world(args.profile, args.seed)
    rng = np.random.default_rng(args.draw_seed)
    rows = []
    t0 = time.perf_counter()
    classes = [c for c in args.classes.split(",") if c]
    for cls in classes:
        pool = [s for s in specs if s.cls == cls]
        for i in rng.choice(len(pool), min(args.per_class, len(pool)), replace=False):
            s = pool[i]
            if args.max_duration_s:
                s = replace(s, duration_s=min(s.duration_s, args.max_duration_s))
            flight, truth = emulate_flight(replace(s, with_background=False))
            snr = flight_body_snr_db(flight)
            snr = snr[np.isfinite(snr)]
            rows.append(
                {
                    "flight_id": s.flight_id,
                    "class": cls,
                    "radar_id": s.radar_id,
                    "duration_s": s.duration_s,
                    "mean_snr_db": float(np.mean(snr)),
                    "std_snr_db": float(np.std(snr)),
                    "effects": ",".join(sorted(truth["effects"])) or "none",
                }
            )
        print(f"{cls}: {sum(r['class'] == cls for r in rows)} flights ({time.perf_counter() - t0:.0f} s)", flush=True)
    df = pd.DataFrame(rows)
    if args.csv:
        df.to_csv(args.csv, index=False)
    out = []
    for cls in classes:
        p_mean, p_std = TABLE_III[cls]
        d = df[df["class"] == cls].reset_index(drop=True)
        draws = draw_flights(d.flight_id, seed=args.draw_seed)
        w = draws.weights / draws.weights.sum(axis=1, keepdims=True)
        row = {"class": cls, "flights": len(d)}
        for col, paper in (("mean_snr_db", p_mean), ("std_snr_db", p_std)):
            m = float(d[col].mean())
            lo, hi = interval(w @ d[col].to_numpy())
            row.update(
                {
                    col: round(m, 2),
                    f"{col}_ci95": f"[{lo:.1f}, {hi:.1f}]",
                    f"{col}_paper": paper,
                    f"{col}_minus_paper": round(m - paper, 2),
                }
            )
        out.append(row)
    table = pd.DataFrame(out)
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(table.to_string(index=False))
    print(f"total {time.perf_counter() - t0:.0f} s")
    return table


if __name__ == "__main__":
    main()
