"""Evaluate the diagnosis on emulated flights with hidden effects (not run in CI).

For every catalog cause (and ``none``) emulate ``--per-cause`` Inspire/Matrice flights
of the default world's kind (both radars, ranges 1-3 km so SNRs as the default world
draws them, magnitudes drawn in the catalog's detectable ranges), diagnose each and
print the confusion matrix, the share of correct causes, the false-alarm rate on
flights without an effect and the parameter errors.

    python benchmarks/eval_diagnosis.py --per-cause 10 --seed 1 --out results/diagnosis/eval.json
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from microdoppler.catalog import CATALOG, CAUSES
from microdoppler.diagnosis import diagnose_flight
from microdoppler.emulator.world import FlightSpec, emulate_flight, measured_snr_db


def draw_effect(cause: str, rng: np.random.Generator) -> dict:
    """A magnitude in the catalog's detectable range (either sign where it has one)."""
    sign = float(rng.choice([-1.0, 1.0]))
    if cause == "none":
        return {}
    if cause == "sideband_asymmetry":
        return {cause: {"asymmetry_db": sign * rng.uniform(3, 6)}}
    if cause == "sideband_fading":
        return {cause: {"fading_std_db": rng.uniform(3, 6), "timescale_s": rng.uniform(1, 2)}}
    if cause == "body_fluctuation":
        return {cause: {"body_std_db": rng.uniform(3, 6)}}
    if cause == "motor_log_lag":
        return {cause: {"lag_s": sign * rng.uniform(0.3, 1.0)}}
    if cause == "motor_speed_scale":
        return {cause: {"scale": 1 + sign * rng.uniform(0.05, 0.12)}}
    if cause == "phase_noise":
        return {cause: {"rms_rad": rng.uniform(0.006, 0.02)}}
    raise ValueError(cause)


def param_ok(cause, truth_p, fit_p) -> bool:
    if cause == "none" or not fit_p:
        return cause == "none"
    k = CAUSES[cause].main_param
    t, f = truth_p[k], fit_p[k]
    if cause == "motor_log_lag":
        return abs(f - t) <= 0.1
    if cause == "motor_speed_scale":
        return abs((f - 1) - (t - 1)) <= 0.3 * abs(t - 1)
    return abs(f - t) <= 0.3 * abs(t)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-cause", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--duration-s", type=float, default=40.0)
    ap.add_argument("--out", default="")
    ap.add_argument("--world", default="", help="instead: diagnose the Inspire/Matrice flights of this emulator "
                    "profile (e.g. default) and compare with the effects it switched on")
    ap.add_argument("--world-seed", type=int, default=20261121)
    a = ap.parse_args(argv)
    if a.world:
        return eval_world(a.world, a.world_seed)
    rng = np.random.default_rng(a.seed)
    rows = []
    t0 = time.time()
    for cause in CATALOG:
        for k in range(a.per_cause):
            eff = draw_effect(cause, rng)
            spec = FlightSpec(f"ev_{cause}_{k}", "drone", drone_model=str(rng.choice(["inspire2", "matrice300"])),
                              radar_id="radar1" if k % 2 == 0 else "radar2", duration_s=a.duration_s,
                              mean_range_m=float(rng.uniform(1000, 3000)), height_m=float(rng.choice([60.0, 80.0, 100.0])),
                              speed_mps=float(rng.uniform(3, 12)), direction=int(rng.choice([1, -1])),
                              effects=eff, seed=int(rng.integers(2 ** 31)))
            flight, truth = emulate_flight(spec)
            snr = measured_snr_db(flight)[0]
            t1 = time.time()
            e = diagnose_flight(flight, config={"figures": False})
            dt = time.time() - t1
            fit = e["extension"]["params"] if e["extension"] else {}
            ok_p = e["cause"] == cause and param_ok(cause, eff.get(cause, {}), fit)
            rows.append({"flight": spec.flight_id, "cause": cause, "named": e["cause"], "radar": spec.radar_id,
                         "model": spec.drone_model, "snr_db": round(snr, 1), "truth": eff.get(cause, {}),
                         "fit": fit, "param_ok": bool(ok_p), "seconds": round(dt, 2)})
            print(f"{spec.flight_id:28s} {spec.radar_id} {spec.drone_model:10s} snr={snr:5.1f} "
                  f"named={e['cause']:20s} truth={eff.get(cause, {})} fit={fit} ({dt:.1f} s)", flush=True)
    names = list(CATALOG)
    cm = np.zeros((len(names), len(names)), int)
    for r in rows:
        cm[names.index(r["cause"]), names.index(r["named"])] += 1
    w = max(len(n) for n in names)
    print("\nconfusion matrix (rows: hidden cause, columns: named cause)")
    print(" " * w + " " + " ".join(f"{n[:8]:>8s}" for n in names))
    for i, n in enumerate(names):
        print(f"{n:{w}s} " + " ".join(f"{v:8d}" for v in cm[i]))
    eff_rows = [r for r in rows if r["cause"] != "none"]
    acc = np.mean([r["named"] == r["cause"] for r in eff_rows])
    fa = np.mean([r["named"] != "none" for r in rows if r["cause"] == "none"])
    pacc = np.mean([r["param_ok"] for r in eff_rows if r["named"] == r["cause"]]) if eff_rows else float("nan")
    hi = [r for r in eff_rows if r["snr_db"] >= 36]
    print(f"\ncorrect causes (flights with an effect): {acc:.1%} ({len(eff_rows)} flights)")
    print(f"correct causes at measured SNR >= 36 dB: {np.mean([r['named'] == r['cause'] for r in hi]):.1%} ({len(hi)})")
    print(f"false alarms on no-effect flights: {fa:.1%}")
    print(f"parameter within tolerance when the cause is right: {pacc:.1%}")
    print(f"mean diagnosis time per 40 s flight: {np.mean([r['seconds'] for r in rows]):.2f} s; total {time.time() - t0:.0f} s")
    if a.out:
        with open(a.out, "w") as fh:
            json.dump({"rows": rows, "confusion": cm.tolist(), "names": names, "accuracy": acc,
                       "false_alarm": fa, "param_accuracy": pacc}, fh, indent=1)
    return 0


def eval_world(profile: str, seed: int) -> int:
    """Diagnose every large-drone flight of an emulated world; compare with its key."""
    from microdoppler.emulator.profiles import plan_world

    n = ok = 0
    for spec in plan_world(profile, seed):
        if spec.target != "drone" or spec.drone_model not in ("inspire2", "matrice300"):
            continue
        flight, truth = emulate_flight(spec)
        e = diagnose_flight(flight, config={"figures": False})
        hidden = list(truth["effects"]) or ["none"]
        n += 1
        ok += e["cause"] in hidden
        print(f"{spec.flight_id:22s} {spec.radar_id} snr={measured_snr_db(flight)[0]:5.1f} key={truth['effects'] or 'none'} "
              f"named={e['cause']} {e['extension']['params'] if e['extension'] else ''}", flush=True)
    print(f"named the switched-on effect (or none) for {ok}/{n} flights")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
