"""The targets of issue 33 pooled over ``eval_any_radar.py --json`` runs at the current code.

Hold-outs are run one at a time, and a change is re-run only on the recordings it can
reach (``eval_any_radar.py --seeds``). This joins the runs into one row per recording,
the later run's row in place of an earlier one (``--update``, file by file in the order
given), keeps the seeds in ``--min-seed``..``--max-seed``, and reports, with 95 %
bootstrap intervals over recordings (the recording is the unit): visible recordings
within 2 %, and within 2 % or marked ambiguous with the truth listed; estimates off by
more than 10 % and not marked ambiguous; visible CPIs within 2 reported sigma; the
visible misses by kind. With ``--json`` the numbers and the rows' provenance are
written.

    .venv/bin/python benchmarks/pool_any_radar_runs.py --runs a.json b.json \\
        --update reach.json --min-seed 7000 --json pooled.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare_any_radar_runs import load  # noqa: E402
from eval_any_radar import cpi_share, off_unmarked, share, within  # noqa: E402


def pool(runs, updates) -> tuple[dict, dict]:
    """One row per recording (a run's rows may not overlap another's; an update's rows
    replace those of recordings already there) and, per recording, the file it is from."""
    rows, source = {}, {}
    for p in runs:
        for n, r in load([p]).items():
            if n in rows:
                raise SystemExit(
                    f"--runs: {p}: {n} is also in {source[n]} (expected disjoint runs; a later run of "
                    "the same recordings goes to --update)"
                )
            rows[n], source[n] = r, str(p)
    for p in updates:
        new = load([p])
        extra = sorted(set(new) - set(rows))
        if extra:
            raise SystemExit(f"--update: {p}: {extra[:5]}: not in --runs (expected a later run of some of them)")
        rows.update(new)
        source.update({n: str(p) for n in new})
    return rows, source


def listed(r) -> bool:
    return bool(r["ok"] and r["ambiguous"] and r.get("truth_listed"))


def summary(rows: list) -> dict:
    vis = lambda r: r["visible"]  # noqa: E731
    out = {}
    for key, num, sel in (
        ("within 2 % (visible)", within, vis),
        ("within 2 % or ambiguous with the truth listed (visible)", lambda r: within(r) or listed(r), vis),
        ("off > 10 % unmarked (with estimate)", off_unmarked, lambda r: r["ok"]),
    ):
        n, p, lo, hi = share(rows, num, sel)
        out[key] = {"n": n, "count": int(sum(num(r) for r in rows if sel(r))), "share": p, "ci95": [lo, hi]}
    n, p, lo, hi = cpi_share(rows, vis)
    out["CPIs within 2 sigma (visible)"] = {"n": n, "share": p, "ci95": [lo, hi]}
    miss = [r for r in rows if r["visible"] and not within(r)]
    out["visible misses"] = {
        "ambiguous": [r["name"] for r in miss if r["ok"] and r["ambiguous"]],
        "ambiguous, truth listed": [r["name"] for r in miss if listed(r)],
        "no estimate": [r["name"] for r in miss if not r["ok"]],
        "unmarked": [r["name"] for r in miss if r["ok"] and not r["ambiguous"]],
    }
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", nargs="+", required=True, metavar="JSON", help="disjoint runs (seed sets)")
    ap.add_argument(
        "--update",
        nargs="+",
        default=[],
        metavar="JSON",
        help="later runs of some of those recordings; their rows replace the earlier ones, in order",
    )
    ap.add_argument("--min-seed", type=int, default=None)
    ap.add_argument("--max-seed", type=int, default=None)
    ap.add_argument("--json", default=None, help="write the pooled numbers here")
    args = ap.parse_args(argv)
    rows, source = pool(args.runs, args.update)
    lo = -np.inf if args.min_seed is None else args.min_seed
    hi = np.inf if args.max_seed is None else args.max_seed
    keep = sorted((r for r in rows.values() if lo <= r["seed"] <= hi), key=lambda r: r["seed"])
    out = summary(keep)
    print(f"recordings {len(keep)} (seeds {keep[0]['seed']}-{keep[-1]['seed']})" if keep else "no recordings")
    for k, v in out.items():
        if k == "visible misses":
            print(k + ": " + "; ".join(f"{kind} {len(names)}" for kind, names in v.items()))
        elif v["n"]:
            c = f"{v['count']} of {v['n']}, " if "count" in v else f"n={v['n']}, "
            print(f"{k}: {c}{100 * v['share']:.1f} % [{100 * v['ci95'][0]:.1f}, {100 * v['ci95'][1]:.1f}]")
    if args.json:
        by_file = {}
        for r in keep:
            by_file.setdefault(source[r["name"]], []).append(r["seed"])
        Path(args.json).write_text(
            json.dumps(
                {
                    "script": "benchmarks/pool_any_radar_runs.py",
                    "runs": list(args.runs),
                    "update": list(args.update),
                    "min_seed": args.min_seed,
                    "max_seed": args.max_seed,
                    "n_recordings": len(keep),
                    "rows_from": {p: len(s) for p, s in by_file.items()},
                    **out,
                },
                indent=1,
                default=float,
            )
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
