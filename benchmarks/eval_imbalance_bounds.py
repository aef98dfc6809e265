"""Does the reported ``imbalance_db`` interval hold the truth, and say when the data
bound it from one side only? (not run in CI)

Draws weak-blade flights from ``tests/independent_generator.py`` (no code shared with
the emulator or the synthesis; its radars ``gen_l``, ``gen_s`` and ``gen_2k`` in turn),
one blade of every rotor ``--low``-``--high`` dB weaker (log-uniform) and, for every
``--one-blade-every``-th flight, one blade alone (the others silent: 300 dB), each
``--duration-s`` long with its own motor log, and diagnoses each
(:func:`microdoppler.diagnosis.diagnose_flight`). Per flight: whether
``blade_imbalance`` is named, its interval (``evidence.intervals.imbalance_db``: low,
high, bound) and whether it holds the truth (a two-sided interval holds it between its
ends, a ``lower`` bound below it; one blade alone is held only by a ``lower`` bound).
Summaries per band of true imbalance, with Wilson 95 % intervals: the share named, the
share held, the share one-sided. Writes ``benchmarks/records/eval_imbalance_bounds_seed<N>.json``.

    OMP_NUM_THREADS=1 PYTHONPATH=src .venv/bin/python benchmarks/eval_imbalance_bounds.py --seed 56100
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from independent_generator import GenCase, make_flight  # noqa: E402

from shares import wilson, write_record  # noqa: E402
from microdoppler.diagnosis import DiagnosisConfig  # noqa: E402
from microdoppler.diagnosis.pipeline import diagnose_flight  # noqa: E402

ONE_BLADE_DB = 300.0
BANDS = [(0, 10), (10, 20), (20, 30), (30, 41), (41, math.inf)]


def holds(iv: dict | None, truth_db: float) -> bool:
    if not iv:
        return False
    lo, hi, bound = iv.get("low"), iv.get("high"), iv.get("bound")
    if bound == "lower":
        return lo is not None and lo <= truth_db
    if bound == "upper":
        return hi is not None and truth_db <= hi and truth_db < ONE_BLADE_DB
    if bound == "two-sided":
        return lo is not None and hi is not None and lo <= truth_db <= hi
    return False


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=56100)
    ap.add_argument("--n", type=int, default=40)
    ap.add_argument("--low", type=float, default=3.0)
    ap.add_argument("--high", type=float, default=40.0)
    ap.add_argument("--one-blade-every", type=int, default=5)
    ap.add_argument("--duration-s", type=float, default=14.0)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    rng = np.random.default_rng([args.seed, 56])
    cfg = DiagnosisConfig()
    t0 = time.time()
    rows = []
    for i in range(args.n):
        one = args.one_blade_every > 0 and i % args.one_blade_every == args.one_blade_every - 1
        db = ONE_BLADE_DB if one else float(np.exp(rng.uniform(np.log(args.low), np.log(args.high))))
        radar = ("gen_l", "gen_s", "gen_2k")[i % 3]
        fid = f"imb{args.seed + i}"
        flight, _ = make_flight(
            GenCase(
                fid,
                seed=int(rng.integers(1 << 30)),
                radar=radar,
                effects={"blade_imbalance": {"imbalance_db": db}},
                duration_s=args.duration_s,
            )
        )
        entry = diagnose_flight(flight, config=cfg)
        named = [c for c in entry.get("causes") or [] if c.get("cause") == "blade_imbalance"]
        iv = None
        value = None
        if named:
            iv = ((named[0].get("evidence") or {}).get("intervals") or {}).get("imbalance_db")
            value = (named[0].get("extension") or {}).get("params", {}).get("imbalance_db")
        row = {
            "flight_id": fid,
            "radar": radar,
            "true_imbalance_db": round(db, 2),
            "cause": entry.get("cause"),
            "named": bool(named),
            "imbalance_db": None if value is None else round(float(value), 2),
            "interval": iv,
            "held": holds(iv, db),
        }
        rows.append(row)
        print(
            f"{fid} {radar} true {db:.1f} dB: {entry.get('cause')}, {value}, {iv and iv.get('bound')} "
            f"[{iv and iv.get('low')}, {iv and iv.get('high')}] held {row['held']} ({time.time() - t0:.0f} s)",
            file=sys.stderr,
            flush=True,
        )
    summary = {}
    for lo, hi in BANDS:
        sel = [r for r in rows if lo <= r["true_imbalance_db"] < hi]
        if not sel:
            continue
        named = [r for r in sel if r["named"]]
        key = f"{lo:g}-{hi:g} dB" if math.isfinite(hi) else "one blade alone"
        k_held = sum(r["held"] for r in named)
        k_one = sum((r["interval"] or {}).get("bound") == "lower" for r in named)
        summary[key] = {
            "n": len(sel),
            "named": len(named),
            "named_wilson95": wilson(len(named), len(sel)),
            "held_of_named": k_held,
            "held_wilson95": wilson(k_held, len(named)),
            "one_sided_lower": k_one,
            "one_sided_wilson95": wilson(k_one, len(named)),
        }
    named = [r for r in rows if r["named"]]
    k = sum(r["held"] for r in named)
    record = {
        "benchmark": "eval_imbalance_bounds",
        "seed": args.seed,
        "n": args.n,
        "low_db": args.low,
        "high_db": args.high,
        "one_blade_every": args.one_blade_every,
        "duration_s": args.duration_s,
        "wall_s": round(time.time() - t0, 1),
        "held_of_named": {
            "count": k,
            "n": len(named),
            "share": round(k / max(len(named), 1), 4),
            "wilson95": wilson(k, len(named)),
        },
        "by_band": summary,
        "rows": rows,
    }
    out = (
        Path(args.json)
        if args.json
        else ROOT / "benchmarks" / "records" / f"eval_imbalance_bounds_seed{args.seed}.json"
    )
    write_record(out, record)
    print(json.dumps({"held_of_named": record["held_of_named"], "by_band": summary}, indent=1))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
