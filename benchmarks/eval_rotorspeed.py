"""Evaluate rotor speeds from the radar (``microdoppler.rotors.speed``) on emulated flights
(not run in CI).

Emulates ``--per-model`` Inspire and Matrice flights (half on each radar, loop centres
500-3000 m away so that the body SNR spans what the default world draws, a third with
sideband asymmetry and a third with sideband fading as in the default world), estimates
each rotor's speed per CPI from the HERM lines alone and compares it with the truth: the
emulator's motor log (the true speeds at the logged stamps, 1 rpm rounding) averaged
over each CPI with the window's power profile, which is what a periodogram line
measures. Also runs ``--negatives`` Mini flights and bird flights relabelled as drones
(both must give no estimate).

Prints tables of the relative error per CPI by visible sideband pairs and by body SNR
(the project's per-timestep SNR, :func:`microdoppler.spectra.snr.flight_body_snr_db`):

* ``mean``: the mean rotor speed against the mean of the four true speeds;
* ``rotor``: each rank (rotors sorted by speed) against the sorted true speeds;
* ``cover``: share of CPIs whose mean-speed error is within 2 reported sigma.

Then the share within 1 % with a 95 % flight-bootstrap interval, by what a user sees
(the reported one-sigma of the mean speed) and by the physics of the CPI (from the
log: the largest rotor's window^2-weighted speed spread within the CPI, and the
closest two rotors' separation in STFT bins at the first harmonic), and the tail
(CPIs with >= 2 pairs and an error over 1 %) by cause: gross (> 5 %), rotor count per
line (assigning each true rotor to its nearest estimated line would be within 1 %),
line positions (every rotor on its own line, or shared lines). Last, whether the
reported uncertainty holds: the share of CPIs whose mean speed (and of ranked rotors
whose speed) lies within 1 and 2 reported sigma, by the I/Q fit's power balance
(:attr:`microdoppler.rotors.speed.RotorEstimate.balance`), with flight-bootstrap
intervals.

    .venv/bin/python benchmarks/eval_rotorspeed.py --per-model 12 --seed 1 --json out.json
    .venv/bin/python benchmarks/eval_rotorspeed.py --per-model 12 --seed 3 --baseline   # against herm-pairs/1
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict

import numpy as np
from scipy.signal.windows import blackmanharris

from microdoppler.stats.bootstrap import draw_flights, interval, ratio_replicates
from microdoppler.diagnosis.measure import cpi_average
from microdoppler.emulator.world import FlightSpec, emulate_flight
from microdoppler.rotors.speed import RotorSpeedConfig, estimate_rotor_speeds
from microdoppler.spectra.snr import flight_body_snr_db

PAIR_BINS = [(0, 0), (1, 1), (2, 2), (3, 3), (4, 4), (5, 99)]
SNR_BINS = [(-99, 20), (20, 30), (30, 40), (40, 50), (50, 60), (60, 99)]
SIGMA_BINS = [(0.0, 0.003), (0.003, 0.004), (0.004, 0.005), (0.005, 0.007), (0.007, 1.0)]
CHIRP_BINS = [(0.0, 0.01), (0.01, 0.02), (0.02, 1.0)]
GAP_BINS = [(0.0, 1.0), (1.0, 2.0), (2.0, 1e9)]
BALANCE_BINS = [(0.0, 0.15), (0.15, 0.3), (0.3, 0.45), (0.45, 0.6), (0.6, 0.75), (0.75, 1.01)]


def true_cpi_speeds(flight, time_s: np.ndarray, n_fft: int) -> np.ndarray:
    """True per-motor speeds [rev/s] averaged over each CPI: float [n_cpi, n_motors]."""
    w = blackmanharris(n_fft, sym=False)
    rev = flight.motors_rpm.astype(np.float64) / 60.0
    return np.column_stack(
        [cpi_average(flight.motors_time_s, rev[:, m], time_s, w, flight.prf_hz) for m in range(rev.shape[1])]
    )


def intra_cpi_spread(flight, time_s: np.ndarray, n_fft: int) -> np.ndarray:
    """Largest rotor's window^2-weighted relative speed spread (std) within each CPI
    (from the log): float [n_cpi]."""
    w = blackmanharris(n_fft, sym=False) ** 2
    k = np.linspace(0, n_fft - 1, 128).astype(int)
    wk = w[k] / w[k].sum()
    tt = time_s[:, None] + (k[None, :] - n_fft / 2) / flight.prf_hz
    rev = flight.motors_rpm.astype(np.float64) / 60.0
    out = np.zeros(len(time_s))
    for m in range(rev.shape[1]):
        x = np.interp(tt, flight.motors_time_s, rev[:, m])
        mu = (x * wk).sum(1)
        out = np.maximum(out, np.sqrt((wk * (x - mu[:, None]) ** 2).sum(1)) / mu)
    return out


def draw_effects(rng: np.random.Generator, k: int) -> dict:
    if k % 3 == 0:
        return {"sideband_asymmetry": {"asymmetry_db": float(rng.choice([-1, 1]) * rng.uniform(3, 6))}}
    if k % 3 == 1:
        return {"sideband_fading": {"fading_std_db": float(rng.uniform(3, 6)), "timescale_s": float(rng.uniform(1, 2))}}
    return {}


def flight_specs(rng: np.random.Generator, per_model: int, duration_s: float) -> list[FlightSpec]:
    """The benchmark's Inspire and Matrice flights, drawn from ``rng`` (seeded
    ``[seed, 4242]``; the negatives are drawn from it afterwards)."""
    specs = []
    for model in ("inspire2", "matrice300"):
        for k in range(per_model):
            specs.append(
                FlightSpec(
                    f"{model}_{k:02d}",
                    "drone",
                    drone_model=model,
                    radar_id=("radar1", "radar2")[k % 2],
                    duration_s=duration_s,
                    mean_range_m=float(rng.uniform(500, 3000)),
                    height_m=float(rng.choice([60.0, 80.0, 100.0])),
                    speed_mps=float(rng.uniform(3, 12)),
                    effects=draw_effects(rng, k // 2),
                    seed=int(rng.integers(2**31)),
                    direction=int(rng.choice([1, -1])),
                )
            )
    return specs


def evaluate(spec: FlightSpec, baseline: bool = False) -> dict:
    flight, truth = emulate_flight(spec)
    t0 = time.perf_counter()
    est = estimate_rotor_speeds(flight)
    dt = time.perf_counter() - t0
    lines = None
    if baseline:  # the periodogram's lines alone (herm-pairs/1), on the same flight
        t1 = time.perf_counter()
        lines = estimate_rotor_speeds(flight, config=RotorSpeedConfig(refine=False))
        dt_lines = time.perf_counter() - t1
    n = len(est.time_s)
    snr = flight_body_snr_db(flight)[:n]
    row = {
        "flight": spec.flight_id,
        "spec": {**asdict(spec), "effects": dict(spec.effects)},
        "model": spec.drone_model,
        "radar": spec.radar_id,
        "range_m": spec.mean_range_m,
        "effects": list(spec.effects),
        "ok": est.ok,
        "reason": est.reason,
        "seconds": dt,
        "snr_db": snr.tolist(),
        "n_pairs": est.n_pairs.tolist(),
    }
    if not est.ok:
        row.update({"mean_err": [np.nan] * n, "rotor_err": [[np.nan] * est.n_motors] * n, "z": [np.nan] * n})
        return row
    tru = true_cpi_speeds(flight, est.time_s, est.n_fft)
    tm = tru.mean(axis=1)
    row["mean_err"] = (est.common_rev_s / tm - 1).tolist()
    if lines is not None:
        row["mean_err_lines"] = (lines.common_rev_s / tm - 1).tolist()
        row["n_pairs_lines"] = lines.n_pairs.tolist()
        row["seconds_lines"] = dt_lines
    row["true_mean_rev_s"] = tm.tolist()
    row["est_mean_rev_s"] = est.common_rev_s.tolist()
    row["rotor_err"] = (est.speeds_rev_s / np.sort(tru, axis=1) - 1).tolist()
    row["z"] = ((est.common_rev_s - tm) / est.common_std_rev_s).tolist()
    row["z_rotor"] = ((est.speeds_rev_s - np.sort(tru, axis=1)) / est.speeds_std_rev_s).tolist()
    row["balance"] = (est.balance if est.balance is not None else np.full(n, np.nan)).tolist()
    row["separated"] = est.separated.tolist()
    row["sigma_rel"] = (est.common_std_rev_s / est.common_rev_s).tolist()
    row["chirp_rel"] = intra_cpi_spread(flight, est.time_s, est.n_fft).tolist()
    ts = np.sort(tru, axis=1)
    row["gap_bins"] = (np.diff(ts, axis=1).min(axis=1) * est.n_blades * est.n_fft / flight.prf_hz).tolist()
    # each true rotor on its nearest estimated line: the error left with the right rotor counts
    d = np.abs(est.speeds_rev_s[:, None, :] - ts[:, :, None])
    near = np.take_along_axis(est.speeds_rev_s, np.where(np.isnan(d), np.inf, d).argmin(axis=2), axis=1)
    row["oracle_err"] = (near.mean(axis=1) / tm - 1).tolist()
    return row


def table(rows: list[dict], key: str, bins, label: str) -> list[str]:
    x = np.concatenate([np.asarray(r[key], float) for r in rows])
    me = np.abs(np.concatenate([np.asarray(r["mean_err"], float) for r in rows]))
    re = np.abs(np.concatenate([np.asarray(r["rotor_err"], float).reshape(len(r["mean_err"]), -1) for r in rows]))
    z = np.abs(np.concatenate([np.asarray(r["z"], float) for r in rows]))
    out = [
        f"| {label} | CPIs | with estimate | mean: median | p90 | p95 | within 1 % | rotor: median | p90 "
        "| cover 2 sigma |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for lo, hi in bins:
        sel = (x >= lo) & (x <= hi) if key == "n_pairs" else (x >= lo) & (x < hi)
        n = int(sel.sum())
        if n == 0:
            continue
        ok = sel & np.isfinite(me)
        k = int(ok.sum())
        name = (
            (f"{lo}" if lo == hi else f">= {lo}")
            if key == "n_pairs"
            else (f"< {hi}" if lo < -50 else (f">= {lo}" if hi > 90 else f"{lo}-{hi}"))
        )
        if k == 0:
            out.append(f"| {name} | {n} | 0 | - | - | - | - | - | - | - |")
            continue
        r = re[ok].ravel()
        r = r[np.isfinite(r)]
        out.append(
            f"| {name} | {n} | {k} ({100 * k / n:.0f} %) | {100 * np.median(me[ok]):.2f} % | "
            f"{100 * np.percentile(me[ok], 90):.2f} % | {100 * np.percentile(me[ok], 95):.2f} % | "
            f"{100 * np.mean(me[ok] <= 0.01):.0f} % | {100 * np.median(r):.2f} % | "
            f"{100 * np.percentile(r, 90):.2f} % | {100 * np.mean(z[ok] <= 2):.0f} % |"
        )
    return out


def within_ci(rows: list[dict], mask) -> str:
    """Share of the selected CPIs within 1 % and its 95 % flight-bootstrap interval;
    ``mask(row)`` gives each flight's selection (bool [n_cpi])."""
    num, den = [], []
    for r in rows:
        me = np.abs(np.asarray(r["mean_err"], float))
        s = mask(r) & np.isfinite(me) & (np.asarray(r["n_pairs"]) >= 2)
        num.append(float(np.sum(me[s] <= 0.01)))
        den.append(float(s.sum()))
    num, den = np.array(num), np.array(den)
    if den.sum() == 0:
        return "| 0 | - | - |"
    draws = draw_flights([r["flight"] for r in rows], seed=0)
    lo, hi = interval(ratio_replicates(num, den, draws))
    return f"| {int(den.sum())} | {100 * num.sum() / den.sum():.1f} % | {100 * lo:.1f}-{100 * hi:.1f} % |"


def tail_tables(rows: list[dict]) -> list[str]:
    """Within 1 % by reported sigma and by the CPI's physics; the tail by cause."""
    ok = [r for r in rows if r["ok"]]
    col = lambda r, k: np.asarray(r[k], float)  # noqa: E731
    out = ["| reported sigma of the mean | CPIs (>= 2 pairs) | within 1 % | 95 % CI (flights) |", "|---|---|---|---|"]
    for lo, hi in SIGMA_BINS:
        out.append(f"| {100 * lo:.1f}-{100 * hi:.1f} % " if hi < 1 else f"| >= {100 * lo:.1f} % ")
        out[-1] += within_ci(ok, lambda r: (col(r, "sigma_rel") >= lo) & (col(r, "sigma_rel") < hi))
    for thr in (0.004, 0.005):
        out.append(f"| <= {100 * thr:.1f} % (all below) " + within_ci(ok, lambda r: col(r, "sigma_rel") <= thr))
    out += [
        "",
        "| intra-CPI speed spread (log) | closest rotors [bins at n = 1] | CPIs (>= 2 pairs) | within 1 % "
        "| 95 % CI (flights) |",
        "|---|---|---|---|---|",
    ]
    for clo, chi in CHIRP_BINS:
        for glo, ghi in GAP_BINS:
            sel = lambda r: (
                (col(r, "chirp_rel") >= clo)
                & (col(r, "chirp_rel") < chi)  # noqa: E731
                & (col(r, "gap_bins") >= glo)
                & (col(r, "gap_bins") < ghi)
            )
            name = f"{100 * clo:.0f}-{100 * chi:.0f} %" if chi < 1 else f">= {100 * clo:.0f} %"
            gname = f"{glo:g}-{ghi:g}" if ghi < 1e8 else f">= {glo:g}"
            out.append(f"| {name} | {gname} " + within_ci(ok, sel))
    me = np.abs(np.concatenate([col(r, "mean_err") for r in ok]))
    orc = np.abs(np.concatenate([col(r, "oracle_err") for r in ok]))
    sep = np.concatenate([np.asarray(r["separated"], bool) for r in ok])
    npairs = np.concatenate([np.asarray(r["n_pairs"]) for r in ok])
    bad = np.isfinite(me) & (npairs >= 2) & (me > 0.01)
    gross = bad & (me > 0.05)
    count = bad & ~gross & (orc <= 0.01)
    rest = bad & ~gross & ~count
    out += [
        "",
        f"tail (>= 2 pairs, error > 1 %): {int(bad.sum())} CPIs: gross > 5 % {int(gross.sum())}; "
        f"rotor count per line {int(count.sum())}; line positions {int(rest.sum())} "
        f"({int((rest & sep).sum())} with every rotor on its own line, {int((rest & ~sep).sum())} shared)",
    ]
    return out


def coverage_table(rows: list[dict]) -> list[str]:
    """Within 1 and 2 reported sigma (CPIs with >= 2 pairs), by the I/Q fit's power
    balance; 95 % flight-bootstrap intervals for the mean speed within 2 sigma."""
    ok = [r for r in rows if r["ok"]]
    out = [
        "| fit balance | CPIs (>= 2 pairs) | mean within 2 sigma | 95 % CI (flights) | mean within 1 sigma "
        "| ranked rotors within 2 sigma | median sigma of the mean |",
        "|---|---|---|---|---|---|---|",
    ]
    draws = draw_flights([r["flight"] for r in ok], seed=0)
    groups = [(f"{lo:.2f}-{min(hi, 1.0):.2f}", lo, hi) for lo, hi in BALANCE_BINS] + [
        ("all refitted", 0.0, 1.01),
        ("all", None, None),
    ]
    for name, lo, hi in groups:
        n2, n1, den, r2, rden, sig = [], [], [], [], [], []
        for r in ok:
            z = np.abs(np.asarray(r["z"], float))
            zr = np.abs(np.asarray(r["z_rotor"], float).reshape(len(z), -1))
            b = np.asarray(r["balance"], float)
            s = np.isfinite(z) & (np.asarray(r["n_pairs"]) >= 2)
            if lo is not None:
                s &= (b >= lo) & (b < hi)
            n2.append(float(np.sum(z[s] <= 2)))
            n1.append(float(np.sum(z[s] <= 1)))
            den.append(float(s.sum()))
            zs = zr[s][np.isfinite(zr[s])]
            r2.append(float(np.sum(zs <= 2)))
            rden.append(float(zs.size))
            sig.append(np.asarray(r["sigma_rel"], float)[s])
        n2, n1, den = np.array(n2), np.array(n1), np.array(den)
        if den.sum() == 0:
            continue
        lo2, hi2 = interval(ratio_replicates(n2, den, draws))
        out.append(
            f"| {name} | {int(den.sum())} | {100 * n2.sum() / den.sum():.1f} % "
            f"| {100 * lo2:.1f}-{100 * hi2:.1f} % "
            f"| {100 * n1.sum() / den.sum():.1f} % | {100 * sum(r2) / max(sum(rden), 1):.1f} % "
            f"| {100 * np.median(np.concatenate(sig)):.3f} % |"
        )
    return out


def baseline_table(rows: list[dict]) -> list[str]:
    """Within 1 % (CPIs with >= 2 pairs), the periodogram's lines alone against the
    estimate with the I/Q fit, on the same CPIs; paired flight bootstrap (95 %)."""
    out = [
        "| CPIs with >= 2 pairs | lines alone (herm-pairs/1) | with the I/Q fit | difference | "
        "median error, lines -> fit | estimation time per flight, lines -> fit |",
        "|---|---|---|---|---|---|",
    ]
    a_n, b_n, den = [], [], []
    ea, eb = [], []
    for r in rows:
        a = np.abs(np.asarray(r["mean_err_lines"], float))
        b = np.abs(np.asarray(r["mean_err"], float))
        s = (np.asarray(r["n_pairs_lines"]) >= 2) & np.isfinite(a) & np.isfinite(b)
        a_n.append(float(np.sum(a[s] <= 0.01)))
        b_n.append(float(np.sum(b[s] <= 0.01)))
        den.append(float(s.sum()))
        ea.append(a[s])
        eb.append(b[s])
    a_n, b_n, den = np.array(a_n), np.array(b_n), np.array(den)
    draws = draw_flights([r["flight"] for r in rows], seed=0)
    ra, rb = ratio_replicates(a_n, den, draws), ratio_replicates(b_n, den, draws)
    (la, ha), (lb, hb), (ld, hd) = interval(ra), interval(rb), interval(rb - ra)
    ea, eb = np.concatenate(ea), np.concatenate(eb)
    out.append(
        f"| {int(den.sum())} | {100 * a_n.sum() / den.sum():.1f} % [{100 * la:.1f}, {100 * ha:.1f}] | "
        f"{100 * b_n.sum() / den.sum():.1f} % [{100 * lb:.1f}, {100 * hb:.1f}] | "
        f"{100 * (b_n.sum() - a_n.sum()) / den.sum():+.1f} [{100 * ld:+.1f}, {100 * hd:+.1f}] points | "
        f"{100 * np.median(ea):.3f} % -> {100 * np.median(eb):.3f} % | "
        f"{np.median([r['seconds_lines'] for r in rows]):.2f} s -> {np.median([r['seconds'] for r in rows]):.2f} s |"
    )
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-model", type=int, default=12, help="Inspire and Matrice flights each (default 12)")
    ap.add_argument("--negatives", type=int, default=6, help="Mini flights and bird flights each (default 6)")
    ap.add_argument("--duration", type=float, default=20.0, help="flight length [s] (default 20)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", default=None, help="also write every flight's per-CPI numbers here")
    ap.add_argument(
        "--baseline",
        action="store_true",
        help="also run the periodogram's lines alone (herm-pairs/1, no I/Q fit) on every flight and "
        "report the paired difference",
    )
    args = ap.parse_args(argv)
    rng = np.random.default_rng([args.seed, 4242])
    specs = flight_specs(rng, args.per_model, args.duration)
    t0 = time.perf_counter()
    rows = []
    for s in specs:
        r = evaluate(s, args.baseline)
        rows.append(r)
        me = np.abs(np.asarray(r["mean_err"], float))
        fin = np.isfinite(me)
        print(
            f"{s.flight_id:15s} {s.radar_id} {s.mean_range_m:6.0f} m  SNR {np.nanmedian(r['snr_db']):5.1f} dB  "
            f"{int(fin.sum()):3d}/{len(me)} CPIs  mean err median "
            f"{100 * np.median(me[fin]) if fin.any() else np.nan:5.2f} %  {r['seconds']:.2f} s"
            + ("" if r["ok"] else f"  no estimate: {r['reason']}"),
            flush=True,
        )
    neg = []
    for k in range(args.negatives):
        seed = int(rng.integers(2**31))
        rid = ("radar1", "radar2")[k % 2]
        fl, _ = emulate_flight(
            FlightSpec(
                f"mini2_{k:02d}",
                "drone",
                drone_model="mini2",
                radar_id=rid,
                duration_s=args.duration,
                mean_range_m=float(rng.uniform(300, 2500)),
                speed_mps=float(rng.uniform(3, 8)),
                seed=seed,
            )
        )
        neg.append(("mini2", estimate_rotor_speeds(fl)))
        kind = ("single", "pair", "small_flock", "large_flock")[k % 4]
        fl, _ = emulate_flight(
            FlightSpec(
                f"bird_{k:02d}",
                "bird",
                bird_kind=kind,
                radar_id=rid,
                duration_s=args.duration,
                mean_range_m=float(rng.uniform(300, 2000)),
                speed_mps=float(rng.uniform(5, 20)),
                seed=seed + 1,
            )
        )
        fl.attrs.update(
            {"target": "drone", "drone_model": "inspire2", "n_motors": 4, "n_blades": 2, "blade_length_m": 0.19}
        )  # pretend: the estimator must still find no rotors
        neg.append((f"bird ({kind})", estimate_rotor_speeds(fl)))
    wall = time.perf_counter() - t0
    print()
    print("\n".join(table(rows, "n_pairs", PAIR_BINS, "visible pairs")))
    print()
    print("\n".join(table(rows, "snr_db", SNR_BINS, "body SNR [dB]")))
    me = np.abs(np.concatenate([np.asarray(r["mean_err"], float) for r in rows]))
    npairs = np.concatenate([np.asarray(r["n_pairs"]) for r in rows])
    sel = np.isfinite(me) & (npairs >= 2)
    print()
    print(
        f"CPIs with >= 2 pairs: {int(sel.sum())}; mean-speed error median {100 * np.median(me[sel]):.2f} %, "
        f"p90 {100 * np.percentile(me[sel], 90):.2f} %, within 1 %: {100 * np.mean(me[sel] <= 0.01):.0f} %"
    )
    sep = np.concatenate([np.asarray(r.get("separated", [False] * len(r["mean_err"])), bool) for r in rows])
    re = np.abs(np.concatenate([np.asarray(r["rotor_err"], float).reshape(len(r["mean_err"]), -1) for r in rows]))
    for name, s in (("every rotor on its own line", sel & sep), ("rotors sharing lines", sel & ~sep)):
        if s.any():
            print(
                f"  {name}: {int(s.sum())} CPIs, mean-speed error median {100 * np.median(me[s]):.2f} %, "
                f"p90 {100 * np.percentile(me[s], 90):.2f} %, within 1 %: {100 * np.mean(me[s] <= 0.01):.0f} %; "
                f"rotors median {100 * np.median(re[s]):.2f} %, p90 {100 * np.percentile(re[s], 90):.2f} %"
            )
    print()
    print("\n".join(tail_tables(rows)))
    print()
    print("\n".join(coverage_table(rows)))
    if args.baseline:
        print()
        print("\n".join(baseline_table([r for r in rows if r["ok"] and "mean_err_lines" in r])))
    print(f"flights with an estimate: {sum(r['ok'] for r in rows)} of {len(rows)}")
    bad = [(k, e) for k, e in neg if e.ok]
    print(
        f"negatives (Mini, birds relabelled as drones): {len(neg) - len(bad)} of {len(neg)} without an estimate"
        + "".join(f"; {k} {e.flight_id}: {e.summary()}" for k, e in bad)
    )
    print(
        f"estimation time per flight: median {np.median([r['seconds'] for r in rows]):.2f} s "
        f"({args.duration:g} s flights); total wall {wall:.0f} s"
    )
    write_json(args, rows)
    return 0


def write_json(args: argparse.Namespace, rows: list[dict]) -> None:
    """Every flight's per-CPI numbers to ``args.json`` (where given), with the arguments."""
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"args": vars(args), "flights": rows}, fh)


if __name__ == "__main__":
    raise SystemExit(main())
