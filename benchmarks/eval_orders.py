"""Rotor speeds off by a factor: marked, and what the diagnosis then says (issue 56; not run in CI).

Draws ``--n`` recordings from the any-radar generator (``microdoppler.examples``:
carriers 1.3-24 GHz, PRFs 2-20 kHz, 4/6/8 rotors of 2 or 3 blades, hovering and
flying; it shares no code with the emulator or the synthesis), every one with one blade
weaker by a drawn 3-12 dB (the case where the rotation-rate lines of a rotor read as
another order's blade-passing lines), ``--duration-s`` long, seeds ``--seed`` + 0, 1, ...
Each is estimated from the radar alone (``estimate_rotor_speeds``). A recording-mean
speed within 10 % of 1/3, 1/2, 2 or 3 times the truth is *off by a factor*; the
question is whether the estimate marks its order ambiguous, and what ``diagnose``
reads on a store carrying that estimate as its motor log: its cause and the fields it
lists as not testable (``setup_not_testable``: ``rotor_order`` where the order is
ambiguous). Wilson 95 % intervals. Writes ``benchmarks/records/eval_orders_seed<N>.json``
(or ``--json``).

    OMP_NUM_THREADS=1 PYTHONPATH=src .venv/bin/python benchmarks/eval_orders.py --seed 56200 --n 40
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from shares import wilson  # noqa: E402
from microdoppler.examples import draw_case, make_recording, true_cpi_means  # noqa: E402
from microdoppler.rotors import estimate_rotor_speeds  # noqa: E402

FACTORS = (1 / 3, 1 / 2, 2.0, 3.0)


def factor_of(ratio: float) -> float | None:
    """The simple factor ``ratio`` lies within 10 % of, else None."""
    for k in FACTORS:
        if abs(np.log(ratio / k)) <= np.log(1.1):
            return k
    return None


def one(seed: int, duration_s: float) -> dict:
    from microdoppler.diagnosis import diagnose_flight
    from microdoppler.diagnosis.measure import Undiagnosable

    weak = float(np.random.default_rng([seed, 56]).uniform(3.0, 12.0))
    case = draw_case(seed, duration_s=duration_s, weak_blade_db=weak)
    flight, truth = make_recording(case)
    t0 = time.perf_counter()
    est = estimate_rotor_speeds(flight)
    row = {
        "recording": case.name,
        "note": f"{case.carrier_hz / 1e9:g} GHz, PRF {case.prf_hz:.0f} Hz, {case.n_rotors}x{case.n_blades}, "
        f"{case.setup}, weak {weak:.1f} dB",
        "n_blades": case.n_blades,
        "setup": case.setup,
        "ok": bool(est.ok and est.valid.any()),
        "seconds": round(time.perf_counter() - t0, 1),
    }
    if not row["ok"]:
        return {**row, "reason": est.reason}
    o = (est.info or {}).get("order") or {}
    v = est.valid
    true_mean = float(np.mean(true_cpi_means(truth, est.time_s, est.n_fft, flight.prf_hz)[v]))
    ratio = float(np.nanmedian(est.common_rev_s[v])) / true_mean
    k = factor_of(ratio)
    row.update(
        ratio=round(ratio, 4),
        factor=k,
        ambiguous=bool(o.get("ambiguous")),
        alternatives_rev_s=o.get("alternatives_rev_s", []),
        true_mean_rev_s=round(true_mean, 2),
    )
    if k is None:
        return row
    try:
        e = diagnose_flight(est.with_flight(flight), config={"figures": False})
    except Undiagnosable as exc:
        return {**row, "diagnosis": "skipped", "reason": exc.reason}
    return {
        **row,
        "diagnosis": e["cause"],
        "causes": [c["cause"] for c in e["causes"]],
        "setup_not_testable": sorted(e.get("setup_not_testable") or {}),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=56200)
    ap.add_argument("--n", type=int, default=40)
    ap.add_argument("--duration-s", type=float, default=6.0)
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    rows = []
    for i in range(a.n):
        r = one(a.seed + i, a.duration_s)
        rows.append(r)
        print(json.dumps(r), file=sys.stderr, flush=True)
    est = [r for r in rows if r["ok"]]
    off = [r for r in est if r.get("factor") is not None]
    unmarked = [r for r in off if not r["ambiguous"]]
    read_none = [r for r in off if r.get("diagnosis") == "none"]
    named = [r for r in read_none if "rotor_order" in r.get("setup_not_testable", [])]
    summary = {
        "n": len(rows),
        "estimated": len(est),
        "off_by_a_factor": len(off),
        "off_by_a_factor_share": wilson(len(off), len(est)),
        "off_and_not_marked": len(unmarked),
        "off_and_not_marked_share_of_estimated": wilson(len(unmarked), len(est)),
        "off_read_none": len(read_none),
        "off_read_none_naming_rotor_order": len(named),
        "by_blades": {
            b: {"estimated": sum(r["n_blades"] == b for r in est), "off": sum(r["n_blades"] == b for r in off)}
            for b in (2, 3)
        },
    }
    out = a.json or ROOT / "benchmarks" / "records" / f"eval_orders_seed{a.seed}.json"
    rec = {
        "benchmark": "eval_orders",
        "seed": a.seed,
        "n": a.n,
        "duration_s": a.duration_s,
        "wall_s": round(time.perf_counter() - t0, 1),
        "summary": summary,
        "rows": rows,
    }
    out.write_text(json.dumps(rec, indent=1) + "\n")
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
