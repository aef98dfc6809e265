"""The pipeline's per-rule times against a recorded run, in one table of ratios.

Reads the per-rule table a run wrote (``RESULTS/reports/rule_times.csv``, rule
``report_rule_times``; rolled from ``RESULTS/benchmarks/`` when the run predates it)
and the run's wall clock (first to last job of its newest Snakemake log), and prints
them beside a record (``records/rule_times_<name>.csv`` and ``.json``): per rule the
total and CPU seconds of each run and their ratio (this run / the record), and the
run's wall clock. A ratio above ``--warn`` (default 1.25) on a rule that took at least
``--min-s`` seconds is flagged, and ``--fail`` makes that the exit status, so a slow
stage shows before it lands.

Usage (after ``snakemake --cores 2`` on a quiet machine)::

    python benchmarks/rule_times.py                      # compare with the newest record
    python benchmarks/rule_times.py --fail               # exit 1 on a regression
    python benchmarks/rule_times.py --reference default_a97806a   # with another record
    python benchmarks/rule_times.py --record default_<commit>     # keep this run as a record
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

import pandas as pd

from shares import write_record

from microdoppler.io.ruletimes import (
    compare_rule_times,
    read_benchmarks,
    read_rule_times,
    rule_times,
    write_rule_table,
)

RECORDS = Path(__file__).resolve().parent / "records"
#: a job's start or end line in a Snakemake log: "[Sun Nov 29 04:44:47 2026]"
STAMP = re.compile(r"^\[(\w{3} \w{3} +\d+ \d\d:\d\d:\d\d \d{4})\]$")


def wall_clock_s(workdir: Path) -> tuple[float | None, str | None]:
    """Seconds from the first to the last job stamp of the newest Snakemake log, and its name."""
    logs = sorted((workdir / ".snakemake" / "log").glob("*.snakemake.log"))
    for log in reversed(logs):
        stamps = [
            datetime.strptime(" ".join(m.group(1).split()), "%a %b %d %H:%M:%S %Y")
            for line in log.read_text(errors="replace").splitlines()
            if (m := STAMP.match(line.strip()))
        ]
        if len(stamps) >= 2:
            return (max(stamps) - min(stamps)).total_seconds(), log.name
    return None, None


def newest_record() -> str | None:
    """The name of the newest record of the embedded default (by its date), or None."""
    dated = []
    for csv_path in RECORDS.glob("rule_times_default_*.csv"):
        meta = csv_path.with_suffix(".json")
        date = json.loads(meta.read_text()).get("date_utc", "") if meta.exists() else ""
        dated.append((date, csv_path.stem.removeprefix("rule_times_")))
    return max(dated)[1] if dated else None


def current_table(results: Path) -> pd.DataFrame:
    table = results / "reports" / "rule_times.csv"
    if table.exists():
        return read_rule_times(table)
    return rule_times(read_benchmarks(results / "benchmarks"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--results", type=Path, default=Path("results"), help="the run's results/ folder")
    ap.add_argument(
        "--reference",
        default="newest",
        help="record to compare with (records/rule_times_<name>.csv; default the newest)",
    )
    ap.add_argument("--record", help="keep this run as records/rule_times_<name>.csv and .json")
    ap.add_argument("--warn", type=float, default=1.25, help="flag a rule slower than this ratio")
    ap.add_argument("--min-s", type=float, default=10.0, help="flag only rules of at least this many seconds")
    ap.add_argument("--fail", action="store_true", help="exit 1 when a rule is flagged")
    args = ap.parse_args(argv)

    table = current_table(args.results)
    wall, log_name = wall_clock_s(args.results.resolve().parent)
    flagged = []
    if args.reference == "newest":
        args.reference = newest_record()
    if args.reference:
        ref_csv = RECORDS / f"rule_times_{args.reference}.csv"
        print(f"against record rule_times_{args.reference}")
        ref = read_rule_times(ref_csv)
        ref_meta = (
            pd.read_json(ref_csv.with_suffix(".json"), typ="series") if ref_csv.with_suffix(".json").exists() else {}
        )
        cmp = compare_rule_times(table, ref)
        print(cmp.to_string(index=False, float_format=lambda x: f"{x:.2f}"))
        ref_wall = ref_meta.get("wall_s") if len(ref_meta) else None
        if wall and ref_wall:
            print(f"\nwall clock: {wall:.0f} s against {ref_wall:.0f} s ({wall / ref_wall:.2f}x)")
        slow = cmp[(cmp.total_ratio > args.warn) & (cmp.total_s >= args.min_s) & (cmp.rule != "all")]
        flagged = list(slow.rule)
        for r in slow.itertuples():
            print(f"slower: {r.rule} {r.total_s:.1f} s against {r.total_s_ref:.1f} s ({r.total_ratio:.2f}x)")
    else:
        print(table.to_string(index=False))
        if wall:
            print(f"\nwall clock: {wall:.0f} s")
    if args.record:
        out = RECORDS / f"rule_times_{args.record}.csv"
        write_rule_table(table, out)
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
        write_record(
            out.with_suffix(".json"),
            {
                "wall_s": wall,
                "snakemake_log": log_name,
                "commit": commit,
                "date_utc": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M"),
                "cores": os.cpu_count(),
            },
        )
        print(f"recorded {out}")
    return 1 if (args.fail and flagged) else 0


if __name__ == "__main__":
    sys.exit(main())
