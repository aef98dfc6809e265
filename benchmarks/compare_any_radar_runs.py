"""Paired difference of two ``eval_any_radar.py --json`` runs on the same recordings.

Before and after, over the recordings in both runs (each a list of JSON files whose rows
are joined, e.g. the five seed sets): visible recordings within 2 %, estimates off by
more than 10 % and not marked ambiguous, estimates off by more than 10 % whether marked
or not, and the visible CPIs within 2 reported sigma,
with the paired difference's 95 % interval from a bootstrap over recordings (the
recording is the unit; the same draws for both runs). Lists every recording whose
error (beyond 1e-4), ambiguity, CPIs or CPIs within 2 sigma changed.

    .venv/bin/python benchmarks/compare_any_radar_runs.py --before a1.json a2.json \\
        --after b1.json b2.json --json paired.json

``--rest-unchanged``: the after run holds only the recordings a change can reach (e.g.
``eval_any_radar.py --seeds``); the others count as unchanged, their before rows in both
(say why in the record, and check a sample of them with a run of their own).
``--before-update``: runs of some of the --before recordings at a later code (e.g. the
recordings an earlier change reached, re-run); their rows replace those in --before,
file by file in the order given.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from eval_any_radar import off_unmarked, within  # noqa: E402

from microdoppler.stats.bootstrap import draw_flights, interval, ratio_replicates  # noqa: E402


def load(paths) -> dict:
    rows = {}
    for p in paths:
        for r in json.loads(Path(p).read_text())["rows"]:
            if r["name"] in rows:
                raise SystemExit(f"{p}: recording {r['name']} appears twice (expected disjoint runs)")
            rows[r["name"]] = r
    return rows


def paired(names, a, b, num_a, num_b, den=None) -> dict:
    """Shares before and after over ``names`` and the paired difference's interval."""
    na = np.array([float(num_a(a[n])) for n in names])
    nb = np.array([float(num_b(b[n])) for n in names])
    d = np.ones(len(names)) if den is None else np.array([float(den(n)) for n in names])
    if not len(names) or d.sum() == 0:
        return {"n": 0}
    draws = draw_flights(list(names), seed=0)
    lo, hi = interval(ratio_replicates(nb, d, draws) - ratio_replicates(na, d, draws))
    return {
        "n": int(d.sum()),
        "before": int(na.sum()),
        "after": int(nb.sum()),
        "diff": float((nb.sum() - na.sum()) / d.sum()),
        "ci95": [float(lo), float(hi)],
    }


def off_any(r) -> bool:
    """Off by more than 10 %, marked ambiguous or not (a gross error the order chose)."""
    return r.get("error") is not None and abs(r["error"]) > 0.10


def changed(ra, rb) -> bool:
    ea, eb = ra.get("error"), rb.get("error")
    err_moved = (ea is None) != (eb is None) or (ea is not None and abs(ea - eb) > 1e-4)
    return err_moved or any(ra.get(k) != rb.get(k) for k in ("ok", "ambiguous", "n_cpi", "n_2sigma"))


def compare(a: dict, b: dict) -> dict:
    names = sorted(set(a) & set(b), key=lambda n: a[n]["seed"])
    vis = [n for n in names if a[n]["visible"]]
    both = [n for n in names if a[n]["ok"] and b[n]["ok"]]
    same_cpis = [n for n in vis if a[n]["ok"] and b[n]["ok"] and a[n]["n_cpi"] == b[n]["n_cpi"]]
    out = {
        "n_recordings": len(names),
        "only_in_one": sorted(set(a) ^ set(b)),
        "within 2 % (visible)": paired(vis, a, b, within, within),
        "off > 10 % unmarked (estimate in both)": paired(both, a, b, off_unmarked, off_unmarked),
        "off > 10 % marked or not (estimate in both)": paired(both, a, b, off_any, off_any),
        "visible CPIs within 2 sigma (same CPIs)": paired(
            same_cpis, a, b, lambda r: r["n_2sigma"], lambda r: r["n_2sigma"], den=lambda n: a[n]["n_cpi"]
        ),
        "changed": [],
    }
    for n in names:
        if changed(a[n], b[n]):
            out["changed"].append(
                {
                    "name": n,
                    **{
                        k: [a[n].get(k), b[n].get(k)]
                        for k in (
                            "carrier_ghz",
                            "n_blades",
                            "visible",
                            "error",
                            "ambiguous",
                            "n_2sigma",
                            "n_cpi",
                            "alternatives_rev_s",
                        )
                    },
                }
            )
    return out


def fmt_row(c) -> str:
    def one(i):
        e = c["error"][i]
        return (
            f"{'-' if e is None else f'{100 * e:+.2f} %'} amb={int(bool(c['ambiguous'][i]))} "
            f"2s {c['n_2sigma'][i]}/{c['n_cpi'][i]}"
        )

    return f"{c['name']} {c['carrier_ghz'][0]} GHz B{c['n_blades'][0]} vis={int(c['visible'][0])}: {one(0)} -> {one(1)}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", nargs="+", required=True, metavar="JSON")
    ap.add_argument("--after", nargs="+", required=True, metavar="JSON")
    ap.add_argument(
        "--before-update",
        nargs="+",
        default=[],
        metavar="JSON",
        help="rows that replace the same recordings' rows in --before (a later run of some)",
    )
    ap.add_argument("--json", default=None, help="write the comparison here")
    ap.add_argument(
        "--rest-unchanged",
        action="store_true",
        help="recordings only in --before count as unchanged (the change cannot reach them)",
    )
    args = ap.parse_args(argv)
    before, after = load(args.before), load(args.after)
    for path in args.before_update:  # in order: a later file's rows replace an earlier one's
        update = load([path])
        extra = sorted(set(update) - set(before))
        if extra:
            raise SystemExit(
                f"--before-update: {path}: {extra[:5]}: not in --before (expected a later run of some of them)"
            )
        before.update(update)
    if args.rest_unchanged:
        extra = sorted(set(after) - set(before))
        if extra:
            raise SystemExit(f"--after: {extra[:5]}: not in --before (expected a subset of its recordings)")
        after = {**before, **after}
    out = compare(before, after)
    out["rest_unchanged"] = bool(args.rest_unchanged)
    print(
        f"recordings {out['n_recordings']}"
        + (f" (in one run only: {out['only_in_one']})" if out["only_in_one"] else "")
    )
    for k in (
        "within 2 % (visible)",
        "off > 10 % unmarked (estimate in both)",
        "off > 10 % marked or not (estimate in both)",
        "visible CPIs within 2 sigma (same CPIs)",
    ):
        p = out[k]
        if p["n"]:
            print(
                f"{k}: {p['before']} -> {p['after']} of {p['n']}, difference {100 * p['diff']:+.1f} "
                f"[{100 * p['ci95'][0]:+.1f}, {100 * p['ci95'][1]:+.1f}] points"
            )
    print(f"changed: {len(out['changed'])}")
    for c in out["changed"]:
        print("  " + fmt_row(c))
    if args.json:
        Path(args.json).write_text(
            json.dumps(
                {
                    "script": "benchmarks/compare_any_radar_runs.py",
                    "before": list(args.before),
                    "before_update": list(args.before_update),
                    "after": list(args.after),
                    **out,
                },
                indent=1,
                default=float,
            )
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
