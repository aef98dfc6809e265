"""Phase noise together with a sideband cause, on the independent generator (issue 34).

A small seeded grid of flights from ``tests/independent_generator.py``: a sideband
cause (``sideband_fading`` or ``sideband_asymmetry``) with phase noise, the same flight
(same seed, so the same fading path) without phase noise, and phase noise alone. Per
flight: the causes named and the sideband tests' statistics (testable, log e-value
against the step-1 threshold, relevant, usable pairs), so that one sees whether the
sideband cause is lost to the test or to the decision.

    python benchmarks/probe_pn_sidebands.py --seed 1 --n 2 --snr-db 30,40 --json probe.json
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from microdoppler.diagnosis import Undiagnosable, diagnose_flight  # noqa: E402
from microdoppler.spectra.snr import flight_body_snr_db  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from independent_generator import GenCase, make_flight  # noqa: E402

FD, AS, PN = "sideband_fading", "sideband_asymmetry", "phase_noise"


def plan(seed: int, n: int, snrs: list[float], variants: list[str]) -> list[dict]:
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        for side in (FD, AS):
            for snr in snrs:
                radar = ["gen_l", "gen_s"][(k + (side == AS)) % 2]
                sp = {
                    FD: {"fading_std_db": float(rng.uniform(3, 6)), "timescale_s": float(rng.uniform(1, 2))},
                    AS: {"asymmetry_db": float(rng.choice([-1, 1]) * rng.uniform(3, 6))},
                }[side]
                pn = {"skirt_dbc_hz": float(rng.uniform(-72, -60)), "shape": str(rng.choice(["gauss", "flicker"]))}
                s = int(rng.integers(2**31))
                speed = float(rng.uniform(5, 20))
                for variant in variants:
                    eff = {"pn+side": {side: sp, PN: pn}, "side": {side: sp}, "pn": {PN: pn}}[variant]
                    out.append(
                        {
                            "id": f"{side[9:11]}{k}_{snr:g}_{variant}",
                            "variant": variant,
                            "side": side,
                            "radar": radar,
                            "snr_db": snr,
                            "speed_mps": speed,
                            "seed": s,
                            "effects": eff,
                        }
                    )
    return out


def run(p: dict) -> dict:
    case = GenCase(p["id"], p["seed"], p["radar"], p["effects"], snr_db=p["snr_db"], speed_mps=p["speed_mps"])
    flight, _ = make_flight(case)
    snr = float(np.nanmean(flight_body_snr_db(flight)))
    t0 = time.perf_counter()
    try:
        e = diagnose_flight(flight, config={"figures": False})
    except Undiagnosable as exc:
        return {**p, "measured_snr_db": snr, "named": [], "reason": exc.reason}
    ev = e["evidence"]
    tests = {}
    for c in (FD, AS, PN):
        t = ev["tests"][c]
        tests[c] = {
            k: t.get(k)
            for k in (
                "testable",
                "log_evalue",
                "relevant",
                "n_heldout_obs",
                "n_pairs_used",
                "fading_std_db",
                "asymmetry_db",
                "skirt_dbc_hz",
                "model_floor_rise_db",
                "reason",
            )
        }
    return {
        **p,
        "measured_snr_db": round(snr, 2),
        "named": [c["cause"] for c in e["causes"]],
        "threshold": ev["log_evalue_threshold"],
        "steps": ev["steps"],
        "tests": tests,
        "dropped": ev["dropped_with_the_others_in_both_models"],
        "seconds": round(time.perf_counter() - t0, 1),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--n", type=int, default=2, help="draws per sideband cause and SNR")
    ap.add_argument("--snr-db", default="30,40", help="nominal body SNRs [dB] (the generator's), comma-separated")
    ap.add_argument("--variants", default="pn+side,side,pn")
    ap.add_argument("--json", default="")
    a = ap.parse_args(argv)
    rows = []
    for p in plan(a.seed, a.n, [float(x) for x in a.snr_db.split(",")], a.variants.split(",")):
        r = run(p)
        rows.append(r)
        t = r.get("tests", {})
        side = t.get(r["side"], {})
        print(
            f"{r['id']:22s} {r['radar']} snr={r['measured_snr_db']:5.1f} true={sorted(r['effects'])} "
            f"named={r['named']} | {r['side'][9:]}: testable={side.get('testable')} "
            f"logE={side.get('log_evalue')} thr={r.get('threshold')} rel={side.get('relevant')} "
            f"pairs={side.get('n_pairs_used')} | pn logE={t.get(PN, {}).get('log_evalue')}",
            flush=True,
        )
    both = [r for r in rows if r["variant"] == "pn+side"]
    print(
        f"\nPN + sideband flights with the sideband cause named: {sum(r['side'] in r['named'] for r in both)}"
        f"/{len(both)}; with PN named: {sum(PN in r['named'] for r in both)}/{len(both)}"
    )
    for v in ("side", "pn"):
        sub = [r for r in rows if r["variant"] == v]
        if sub:
            want = (lambda r: r["side"]) if v == "side" else (lambda r: PN)
            spur = sum(bool(set(r["named"]) - set(r["effects"]) - {"unexplained"}) for r in sub)
            print(
                f"{v} alone: named {sum(want(r) in r['named'] for r in sub)}/{len(sub)}, spurious catalog causes "
                f"{spur}/{len(sub)}"
            )
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
