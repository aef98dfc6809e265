"""Evaluate the diagnosis on emulated flights with hidden effects (not run in CI).

For every catalog cause (and ``none``) emulate ``--per-cause`` Inspire/Matrice flights
of the default world's kind (both radars, ranges 1-3 km so SNRs as the default world
draws them, magnitudes drawn in the catalog's detectable ranges), diagnose each and
print the confusion matrix, the share of correct causes, the false-alarm rate on
flights without an effect, the parameter errors and the fading timescale's error.

The draws are fresh random by default (a seed from os.urandom, printed; ``--seed``
reproduces a run); ``tests/test_diagnosis.py`` uses a fixed list of seeded cases.

    python benchmarks/eval_diagnosis.py --per-cause 10 --out results/diagnosis/eval.json
    python benchmarks/eval_diagnosis.py --per-cause 1 --duration-s 20 --causes none,motor_log_lag   # a quick check
"""

from __future__ import annotations

import argparse
import json
import secrets
import time

import numpy as np

from microdoppler.catalog import CATALOG, CAUSES
from microdoppler.diagnosis import Undiagnosable, diagnose_flight
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


def diagnose_one(flight) -> tuple[str, dict, dict]:
    """(named cause or "skipped", the first cause's params, the report entry)."""
    try:
        e = diagnose_flight(flight, config={"figures": False})
    except Undiagnosable as exc:
        return "skipped", {}, {"cause": "skipped", "causes": [], "reason": exc.reason}
    return e["cause"], (e["causes"][0]["extension"]["params"] if e["causes"] else {}), e


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-cause", type=int, default=10)
    ap.add_argument("--seed", type=int, default=None, help="default: fresh random (printed)")
    ap.add_argument("--causes", default="", help="comma-separated causes (default: the whole catalog)")
    ap.add_argument("--duration-s", type=float, default=40.0)
    ap.add_argument("--out", default="")
    ap.add_argument("--world", default="", help="instead: diagnose the Inspire/Matrice flights of this emulator "
                    "profile (e.g. default) and compare with the effects it switched on")
    ap.add_argument("--world-seed", type=int, default=20261121)
    a = ap.parse_args(argv)
    if a.world:
        return eval_world(a.world, a.world_seed)
    seed = a.seed if a.seed is not None else secrets.randbits(32)
    print(f"seed {seed} (rerun: --seed {seed})", flush=True)
    causes = [c.strip() for c in a.causes.split(",") if c.strip()] or list(CATALOG)
    for c in causes:
        if c not in CATALOG:
            ap.error(f"--causes: {c!r} is not a catalog cause ({', '.join(CATALOG)})")
    rng = np.random.default_rng(seed)
    rows = []
    t0 = time.time()
    for cause in causes:
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
            named, fit, e = diagnose_one(flight)
            dt = time.time() - t1
            ok_p = named == cause and param_ok(cause, eff.get(cause, {}), fit)
            held = bool(e["causes"][0]["gain"]["held_out"]) if e["causes"] else None
            rows.append({"flight": spec.flight_id, "cause": cause, "named": named, "radar": spec.radar_id,
                         "model": spec.drone_model, "snr_db": round(snr, 1), "truth": eff.get(cause, {}),
                         "fit": fit, "param_ok": bool(ok_p), "held_out": held, "reason": e.get("reason"),
                         "seconds": round(dt, 2)})
            print(f"{spec.flight_id:28s} {spec.radar_id} {spec.drone_model:10s} snr={snr:5.1f} "
                  f"named={named:20s} truth={eff.get(cause, {})} fit={fit} "
                  f"{e.get('reason') or ''}({dt:.1f} s)", flush=True)
    names = [*CATALOG, "skipped"]
    cm = np.zeros((len(names), len(names)), int)
    for r in rows:
        cm[names.index(r["cause"]), names.index(r["named"])] += 1
    w = max(len(n) for n in names)
    print("\nconfusion matrix (rows: hidden cause, columns: named cause)")
    print(" " * w + " " + " ".join(f"{n[:8]:>8s}" for n in names))
    for i, n in enumerate(names[:-1]):
        print(f"{n:{w}s} " + " ".join(f"{v:8d}" for v in cm[i]))

    def share(xs):
        return float(np.mean(xs)) if len(xs) else float("nan")

    eff_rows = [r for r in rows if r["cause"] != "none"]
    acc = share([r["named"] == r["cause"] for r in eff_rows])
    fa = share([r["named"] not in ("none", "skipped") for r in rows if r["cause"] == "none"])
    pacc = share([r["param_ok"] for r in eff_rows if r["named"] == r["cause"]])
    hi = [r for r in eff_rows if r["snr_db"] >= 36]
    print(f"\ncorrect causes (flights with an effect): {acc:.1%} ({len(eff_rows)} flights)")
    print(f"correct causes at measured SNR >= 36 dB: {share([r['named'] == r['cause'] for r in hi]):.1%} ({len(hi)})")
    print(f"false alarms on no-effect flights: {fa:.1%}")
    print(f"skipped: {sum(r['named'] == 'skipped' for r in rows)} of {len(rows)}")
    print(f"parameter within tolerance when the cause is right: {pacc:.1%}")
    print(f"named causes with a held-out gain: {sum(bool(r['held_out']) for r in rows)} of "
          f"{sum(r['held_out'] is not None for r in rows)}")
    ts = [r["fit"]["timescale_s"] / r["truth"]["timescale_s"] for r in rows
          if r["cause"] == r["named"] == "sideband_fading" and "timescale_s" in r["fit"]]
    if ts:
        lr = np.abs(np.log(ts))
        print(f"sideband_fading timescale_s fit/truth: median {np.exp(np.median(np.log(ts))):.2f}, "
              + ", ".join(f"within x{f:g}: {np.mean(lr <= np.log(f)):.0%}" for f in (1.5, 2, 3)) + f" ({len(ts)} flights)")
    print(f"mean diagnosis time per {a.duration_s:g} s flight: {np.mean([r['seconds'] for r in rows]):.2f} s; total {time.time() - t0:.0f} s")
    if a.out:
        with open(a.out, "w") as fh:
            json.dump({"seed": seed, "rows": rows, "confusion": cm.tolist(), "names": names, "accuracy": acc,
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
        named, fit, e = diagnose_one(flight)
        hidden = list(truth["effects"]) or ["none"]
        n += 1
        ok += named in hidden
        print(f"{spec.flight_id:22s} {spec.radar_id} snr={measured_snr_db(flight)[0]:5.1f} key={truth['effects'] or 'none'} "
              f"named={named} {fit or e.get('reason') or ''}", flush=True)
    print(f"named the switched-on effect (or none) for {ok}/{n} flights")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
