"""Per-rule cluster resources from the Snakemake ``benchmark:`` files of a run.

    .venv/bin/python benchmarks/cluster_resources.py [results/benchmarks] [--scale 1] [--headroom 1.5]

Reads every ``results/benchmarks/**/*.tsv`` (columns ``s`` and ``max_rss`` [MB]),
takes per rule the largest wall time and resident memory over its jobs, and prints a
``set-resources:`` block for a Snakemake profile (``profiles/slurm/config.yaml``):
``mem_mb`` = headroom x max_rss (at least 500 MB) and ``runtime`` [min] = 2 x
headroom x scale x wall time + 5 min. ``--scale`` multiplies the wall times, e.g. the
ratio of flights between the run measured and the campaign to run. The rule of a
file is its name (``<rule>.tsv``) or its folder (``<rule>/<wildcards>.tsv``).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import pandas as pd


def measured(bench_dir) -> pd.DataFrame:
    """Per rule: jobs, largest wall time [s] and max RSS [MB] over its benchmark files."""
    bench_dir = Path(bench_dir)
    rows = []
    for f in sorted(bench_dir.rglob("*.tsv")):
        rule = f.stem if f.parent == bench_dir else f.relative_to(bench_dir).parts[0]
        df = pd.read_csv(f, sep="\t")
        rss = pd.to_numeric(df.get("max_rss"), errors="coerce")
        rows.append({"rule": rule, "s": float(df["s"].max()), "max_rss": float(rss.max())})
    if not rows:
        raise SystemExit(f"no benchmark files under {bench_dir}")
    df = pd.DataFrame(rows)
    return df.groupby("rule").agg(jobs=("s", "size"), s=("s", "max"), max_rss=("max_rss", "max"))


def resources(table: pd.DataFrame, *, scale: float = 1.0, headroom: float = 1.5) -> dict:
    out = {}
    for rule, r in table.iterrows():
        rss = r["max_rss"] if math.isfinite(r["max_rss"]) else 500.0
        out[rule] = {
            "mem_mb": int(max(500, math.ceil(headroom * rss / 100) * 100)),
            "runtime": int(math.ceil(2 * headroom * scale * r["s"] / 60) + 5),
        }
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("bench_dir", nargs="?", default="results/benchmarks")
    p.add_argument("--scale", type=float, default=1.0, help="wall-time multiplier (campaign size / measured)")
    p.add_argument("--headroom", type=float, default=1.5, help="memory and time safety factor")
    a = p.parse_args(argv)
    table = measured(a.bench_dir)
    print("# measured (largest job per rule):")
    for rule, r in table.iterrows():
        print(f"#   {rule}: {int(r['jobs'])} jobs, {r['s']:.1f} s, {r['max_rss']:.0f} MB")
    print("set-resources:")
    for rule, res in resources(table, scale=a.scale, headroom=a.headroom).items():
        print(f"  {rule}:\n    mem_mb: {res['mem_mb']}\n    runtime: {res['runtime']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
