"""Rotor speeds from the radar on recordings the project did not shape (not run in CI).

Draws ``--n`` recordings from ``tests/any_radar.py`` (its own rotor echo: point
scatterers along each blade; carriers 1.3-24 GHz, PRFs 2-20 kHz, 4/6/8 rotors of 2 or 3
blades, blade lengths 0.05-0.25 m, tip speeds 60-110 m/s, hovering and flying, equal
blades and one blade 3-10 dB weaker, body SNR 30-45 dB; seeds ``--seed`` + 0, 1, ...),
estimates the rotor speeds with :func:`microdoppler.rotors.speed.estimate_rotor_speeds`
(default settings: the lines, the order check of :mod:`microdoppler.rotors.order`, the
I/Q fit) and scores each recording (the unit) against the truth, the true speeds
averaged over each CPI with the window's power profile:

* ``error``: the median over the recording's CPIs of the mean rotor speed's relative
  error; ``within 2 %`` / ``off > 10 %`` from it;
* ``ambiguous``: the order check named alternatives (``info["order"]``); ``truth
  listed``: the chosen speed or an alternative lies within 3 % of the truth;
* ``2 sigma``: the share of the CPIs (pooled, with the recording as the bootstrap
  unit) whose error lies within twice the reported uncertainty;
* ``visible``: the generator's rule: the first blade-passing pair lies unfolded inside
  +-PRF/2, away from 0 Hz, and stands 10 dB over the noise per bin (the pair alone:
  each rotor's Fourier coefficients at +-B of its rotation rate; before 15e7046 the
  whole blade signal's peak near +-B f, which at 9.4-24 GHz was a folded higher order
  or another rotor's line on 4 of seeds 1000-1071 and 2 of 5000-5071).

Seeds 1000-1071 are the benchmark the estimator was worked on (issue 33); seeds
5000-5071 were first run after that work, as a hold-out, and then worked on too;
seeds 7000-7071 were first run at 6fc19f7, the second hold-out; seeds 9000-9071 at
17ba26f (the order check as at 6fc19f7), the third; seeds 11000-11071 at e45beb1 (the
same order check, the I/Q fit on the model's band), the fourth; seeds 13000-13071 at
c69c6a9 (a tail window without a line expects the tip's fall-off), the fifth; seeds
15000-15071 at 65e8aa0 (rotation-rate lines alone set their level; a lone pair under the
pair threshold), the sixth; seeds 17000-17071 at c5f9c33 (a lone pair whose second order
would rarely show, ``lone_p_min``), the seventh; seeds 19000-19071 at ba48f5d (the blade-tip
speed's prior), the eighth; seeds 21000-21071 at 4be7b3d (the tail beyond the tips'
Doppler at the lines' level, ``tail_level``), the ninth; seeds 23000-23071 at 6a93c0e
(speeds split between two rates scaled to the chosen one, ``depart_max``), the tenth;
seeds 25000-25071 at 3566b56 (the tip speed's prior at log sd 0.3), the eleventh. A next
hold-out takes seeds never run (e.g. from 27000); ``--seeds`` runs a list (the
recordings a change can reach); ``compare_any_radar_runs.py`` pairs two runs by
recording; ``pool_any_radar_runs.py`` pools runs at the current code (later rows in
place of earlier ones) into the targets' numbers. Rows carry ``lone_pair`` (why a lone
pair was read as the comb), ``rescued`` (the order check's search where the lines found
no comb) and, from 4be7b3d, what a later change's reach needs: the lines' extent and
strongest line, the tail allowed, the candidates (rate, log-likelihood, extent ratio,
origin) and (later) the rotors moved to the median and the speeds' departure from the
chosen rate (``departs``, from e302771).

Targets (issue 33): within 2 % on >= 95 % of the visible recordings; never off by more
than 10 % unless ambiguous; >= 95 % of errors within 2 sigma. Prints a table by carrier,
set-up and blade balance with 95 % bootstrap intervals over recordings, and the
estimator's CPU seconds per minute of recording (``time.process_time`` of the
estimation alone; ``--timing`` also times one 60 s recording of 4 rotors at 10 kHz).
Writes every recording's numbers to ``--json`` and the table to ``--csv``.

    OMP_NUM_THREADS=1 PYTHONPATH=src .venv/bin/python benchmarks/eval_any_radar.py --n 60 --seed 1000 \\
        --json any_radar.json --csv any_radar.csv --timing

Runs side by side (e.g. ``--n 36 --seed 7000`` and ``--n 36 --seed 7036``, one per core)
are joined, rows in seed order, with ``--join a.json b.json --json all.json --csv all.csv``.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from any_radar import draw_case, make_recording, true_cpi_means  # noqa: E402

from microdoppler.rotors.speed import RotorSpeedConfig, estimate_rotor_speeds  # noqa: E402
from microdoppler.stats.bootstrap import draw_flights, interval, ratio_replicates  # noqa: E402


def evaluate(case) -> dict:
    """One recording's row (JSON-serialisable)."""
    flight, truth = make_recording(case)
    t0 = time.process_time()
    est = estimate_rotor_speeds(flight)
    dt = time.process_time() - t0
    o = est.info.get("order", {}) if est.ok else {}
    row = {
        "name": case.name,
        "seed": case.seed,
        "carrier_ghz": case.carrier_hz / 1e9,
        "prf_hz": case.prf_hz,
        "n_rotors": case.n_rotors,
        "n_blades": case.n_blades,
        "blade_length_m": case.blade_length_m,
        "setup": case.setup,
        "balance": case.balance,
        "weak_blade_db": case.weak_blade_db,
        "visible": truth["visible"],
        "first_pair_db": truth["first_pair_db"],
        "duration_s": case.duration_s,
        "seconds": dt,
        "ok": est.ok,
        "reason": est.reason,
        "ambiguous": bool(o.get("ambiguous", False)),
        "alternatives_rev_s": o.get("alternatives_rev_s", []),
        "relative_likelihood": o.get("relative_likelihood", []),
        "ratio_to_lines": o.get("ratio_to_lines"),
        "remeasured": o.get("remeasured"),
        "coverage": o.get("coverage"),
        "extent_hz": o.get("extent_hz"),
        "extent_over_tip_doppler": o.get("extent_over_tip_doppler"),
        "top_db": o.get("top_db"),
        "tail_harmonics": o.get("tail_harmonics"),
        "n_rotors_to_median": o.get("n_rotors_to_median"),
        "chosen_rev_s": o.get("chosen_rev_s"),
        "departs": o.get("departs"),
        "candidates": [
            {k: c.get(k) for k in ("rev_s", "loglik", "extent_ratio", "tip_mach", "origin")}
            for c in o.get("candidates", [])
        ],
        "n_cpi_departing": est.info.get("n_cpi_departing", 0) if est.ok else 0,
        "lone_pair": est.info.get("lone_pair"),
        "rescued": o.get("rescued"),
    }
    if not est.ok:
        row.update({"error": None, "true_rev_s": float(np.mean(truth["rev_s"])), "n_cpi": 0, "n_2sigma": 0})
        return row
    v = est.valid
    tm = true_cpi_means(truth, est.time_s, est.n_fft, flight.prf_hz).mean(axis=1)
    err = est.common_rev_s[v] / tm[v] - 1
    z = (est.common_rev_s[v] - tm[v]) / est.common_std_rev_s[v]
    e = float(np.median(err))
    chosen = float(np.median(est.common_rev_s[v]))
    true_mean = float(np.median(tm[v]))
    listed = [chosen] + list(row["alternatives_rev_s"])
    row.update(
        {
            "error": e,
            "true_rev_s": true_mean,
            "est_rev_s": chosen,
            "n_cpi": int(v.sum()),
            "n_2sigma": int(np.sum(np.abs(z) <= 2)),
            "median_sigma_rel": float(np.median(est.common_std_rev_s[v] / est.common_rev_s[v])),
            "truth_listed": bool(any(abs(s / true_mean - 1) <= 0.03 for s in listed)),
        }
    )
    return row


def share(rows, num_key, sel) -> tuple[int, float, float, float]:
    """(n, share, 95 % interval) of ``num_key(row)`` over rows with ``sel(row)``."""
    rs = [r for r in rows if sel(r)]
    if not rs:
        return 0, np.nan, np.nan, np.nan
    num = np.array([float(num_key(r)) for r in rs])
    den = np.ones(len(rs))
    draws = draw_flights([r["name"] for r in rs], seed=0)
    lo, hi = interval(ratio_replicates(num, den, draws))
    return len(rs), float(num.mean()), lo, hi


def cpi_share(rows, sel) -> tuple[int, float, float, float]:
    """Pooled share of CPIs within 2 sigma, the recording as the unit."""
    rs = [r for r in rows if sel(r) and r["ok"] and r["n_cpi"] > 0]
    if not rs:
        return 0, np.nan, np.nan, np.nan
    num = np.array([r["n_2sigma"] for r in rs], float)
    den = np.array([r["n_cpi"] for r in rs], float)
    draws = draw_flights([r["name"] for r in rs], seed=0)
    lo, hi = interval(ratio_replicates(num, den, draws))
    return int(den.sum()), float(num.sum() / den.sum()), lo, hi


def fmt(t) -> str:
    n, p, lo, hi = t
    return "-" if n == 0 else f"{100 * p:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}] (n={n})"


def within(r) -> bool:
    return r["ok"] and abs(r["error"]) <= 0.02


def off_unmarked(r) -> bool:
    return r["ok"] and abs(r["error"]) > 0.10 and not r["ambiguous"]


def table(rows) -> list[dict]:
    groups = [("all", lambda r: True)]
    for c in sorted({r["carrier_ghz"] for r in rows}):
        groups.append((f"{c:g} GHz", lambda r, c=c: r["carrier_ghz"] == c))
    for s in ("hover", "flying"):
        groups.append((s, lambda r, s=s: r["setup"] == s))
    for b in ("equal", "one weak blade"):
        groups.append((b, lambda r, b=b: r["balance"] == b))
    out = []
    for name, sel in groups:
        vis = lambda r, sel=sel: sel(r) and r["visible"]  # noqa: E731
        out.append(
            {
                "group": name,
                "recordings": sum(1 for r in rows if sel(r)),
                "visible": sum(1 for r in rows if vis(r)),
                "with estimate (visible)": sum(1 for r in rows if vis(r) and r["ok"]),
                "within 2 % (visible)": fmt(share(rows, within, vis)),
                "ambiguous (visible)": fmt(share(rows, lambda r: r["ambiguous"], vis)),
                "off > 10 % unmarked (all with estimate)": fmt(
                    share(rows, off_unmarked, lambda r, sel=sel: sel(r) and r["ok"])
                ),
                "CPIs within 2 sigma (visible)": fmt(cpi_share(rows, vis)),
                "CPIs within 2 sigma (all)": fmt(cpi_share(rows, sel)),
            }
        )
    return out


def summary(rows, wall: float) -> list[str]:
    """The run's summary lines: visible within 2 %, off > 10 % unmarked, the estimator's CPU."""
    vis = [r for r in rows if r["visible"]]
    bad = [r for r in rows if off_unmarked(r)]
    amb_vis_listed = [r for r in vis if r["ok"] and r["ambiguous"] and abs(r["error"]) > 0.02]
    secs = sum(r["seconds"] for r in rows)
    dur = sum(r["duration_s"] for r in rows)
    sub = [r for r in rows if r["n_rotors"] == 4 and r["prf_hz"] <= 10000]
    per_min_sub = 60 * sum(r["seconds"] for r in sub) / max(sum(r["duration_s"] for r in sub), 1e-9)
    return [
        f"visible recordings within 2 %: {sum(within(r) for r in vis)} of {len(vis)}; of the others "
        f"{sum(1 for r in amb_vis_listed if r['truth_listed'])} of {len(amb_vis_listed)} ambiguous with the "
        f"truth listed",
        f"off by > 10 % and not marked ambiguous: {len(bad)} of {sum(r['ok'] for r in rows)} with an estimate"
        + "".join(f"; {r['name']} {100 * r['error']:+.1f} %" for r in bad),
        f"estimator CPU: {60 * secs / dur:.1f} s per minute of recording over all ({secs:.0f} s for {dur:.0f} s); "
        f"4 rotors at <= 10 kHz: {per_min_sub:.1f} s per minute ({len(sub)} recordings); wall {wall:.0f} s",
    ]


def timing_run(seconds: float = 60.0) -> dict:
    """CPU seconds of one estimate of a 60 s recording: 4 two-blade rotors at 10 kHz PRF,
    3.3 GHz, flying (the issue's cost target: <= 60 s per minute on one core)."""
    case = draw_case(
        7,
        duration_s=seconds,
        carrier_hz=3.3e9,
        prf_hz=10000.0,
        n_rotors=4,
        n_blades=2,
        blade_length_m=0.12,
        tip_speed_mps=85.0,
        setup="flying",
        radial_speed_mps=6.0,
        weak_blade_db=0.0,
        blade_to_body_db=0.0,
    )
    flight, _ = make_recording(case)
    parts = {}
    for name, kw in (
        ("lines", dict(config=RotorSpeedConfig(refine=False), order=False)),
        ("lines + order", dict(config=RotorSpeedConfig(refine=False))),
        ("default (lines + order + I/Q fit)", {}),
    ):
        t0 = time.process_time()
        est = estimate_rotor_speeds(flight, **kw)
        parts[name] = 60 * (time.process_time() - t0) / seconds
    dt = parts["default (lines + order + I/Q fit)"] * seconds / 60
    return {
        "recording_s": seconds,
        "cpu_s": dt,
        "cpu_s_per_minute": 60 * dt / seconds,
        "n_cpi": len(est.time_s),
        "cpu_s_per_minute_by_part": parts,
        "ok": est.ok,
        "order": {k: est.info.get("order", {}).get(k) for k in ("ratio_to_lines", "ambiguous")},
    }


def join(args) -> int:
    """Join runs' JSON (e.g. two halves run side by side): rows in seed order, the table,
    the summary lines (wall: the longest run's) and the first run's timing."""
    runs = [json.loads(Path(p).read_text()) for p in args.join]
    rows = sorted((r for run in runs for r in run["rows"]), key=lambda r: r["seed"])
    if len({r["seed"] for r in rows}) != len(rows):
        raise SystemExit(f"--join: {', '.join(args.join)}: a seed appears twice (expected disjoint runs)")
    wall = max(run["wall_s"] for run in runs)
    tab = table(rows)
    lines = summary(rows, wall)
    print("\n".join(lines))
    timing = next((run["timing"] for run in runs if run.get("timing")), None)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(
                {
                    "joined": list(args.join),
                    "summary_lines": lines,
                    "rows": rows,
                    "table": tab,
                    "timing": timing,
                    "wall_s": wall,
                },
                fh,
                indent=1,
                default=float,
            )
    if args.csv:
        with open(args.csv, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(tab[0]))
            w.writeheader()
            w.writerows(tab)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=60, help="recordings (default 60)")
    ap.add_argument("--seed", type=int, default=1000, help="first seed (default 1000; seeds 1-99 were used to tune)")
    ap.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        default=None,
        metavar="SEED",
        help="instead of --n/--seed: these seeds (e.g. a set's recordings a change can reach)",
    )
    ap.add_argument("--duration", type=float, default=6.0, help="recording length [s] (default 6)")
    ap.add_argument("--json", default=None, help="write every recording's numbers here")
    ap.add_argument("--csv", default=None, help="write the table here")
    ap.add_argument("--timing", action="store_true", help="also time one 60 s recording (4 rotors, 10 kHz)")
    ap.add_argument(
        "--join",
        nargs="+",
        default=None,
        metavar="HALF_JSON",
        help="instead of running: join these runs' rows (halves run side by side) in seed order, "
        "their table and summary to --json/--csv",
    )
    args = ap.parse_args(argv)
    if args.join:
        return join(args)
    rows = []
    t0 = time.perf_counter()
    for seed in args.seeds or range(args.seed, args.seed + args.n):
        case = draw_case(seed, duration_s=args.duration)
        r = evaluate(case)
        rows.append(r)
        e = "   -   " if r["error"] is None else f"{100 * r['error']:+6.2f}%"
        print(
            f"{r['name']} {r['carrier_ghz']:4.1f} GHz prf {r['prf_hz']:6.0f} M{r['n_rotors']} B{r['n_blades']} "
            f"{r['setup']:6s} {r['balance']:14s} vis={int(r['visible'])} err {e} amb={int(r['ambiguous'])} "
            f"listed={int(r.get('truth_listed', False))} 2sig {r['n_2sigma']}/{r['n_cpi']} {r['seconds']:.1f} s"
            + ("" if r["ok"] else f"  no estimate: {r['reason'][:70]}"),
            flush=True,
        )
    wall = time.perf_counter() - t0
    tab = table(rows)
    print()
    keys = list(tab[0])
    print("| " + " | ".join(keys) + " |")
    print("|" + "---|" * len(keys))
    for t in tab:
        print("| " + " | ".join(str(t[k]) for k in keys) + " |")
    print()
    for line in summary(rows, wall):
        print(line)
    timing = None
    if args.timing:
        timing = timing_run()
        print(
            f"timing run: {timing['recording_s']:.0f} s recording, 4 rotors, 10 kHz PRF: {timing['cpu_s']:.1f} CPU s "
            f"({timing['cpu_s_per_minute']:.1f} s per minute, {timing['n_cpi']} CPIs); per minute by part: "
            + ", ".join(f"{k} {v:.1f} s" for k, v in timing["cpu_s_per_minute_by_part"].items())
        )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(
                {"args": vars(args), "rows": rows, "table": tab, "timing": timing, "wall_s": wall},
                fh,
                indent=1,
                default=float,
            )
    if args.csv:
        with open(args.csv, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=keys)
            w.writeheader()
            w.writerows(tab)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
