"""What the I/Q fit's likelihood allows: each CPI's fit started at the true rotor speeds
(not run in CI).

The tail of :mod:`microdoppler.rotors.fit` (CPIs with >= 2 visible pairs whose mean rotor
speed is off by over 1 %) is either a *search* failure (a better optimum of the fit's
cost exists, near the truth, and the starts from the periodogram's lines never reach
it) or a *likelihood* failure (the wrong composition fits the samples at least as well
as the truth: no search of this model can mend it). This benchmark tells them apart.

It emulates the flights of ``eval_rotorspeed.py`` (same specs, same seeds), runs
:func:`microdoppler.rotors.speed.estimate_rotor_speeds` with every CPI's fit recorded,
and refits each CPI with >= 2 pairs from the truth: the true per-rotor speeds (window^2
mean over the CPI, from the emulator's log) and rates (window^2-weighted slope), with
the chosen fit's body Doppler, through the same harmonics (``harmonics[0]`` then
``harmonics[-1]``). The truth-started fit's cost (residual plus the rate prior, the
fit's own criterion) is compared with the chosen fit's:

* ``search``: the truth start reaches a lower cost (by more than ``--margin`` noise
  variances) and is within 1 %: a better search of this model would mend the CPI;
* ``likelihood``: the truth start is within 1 % but its cost is not lower: the model
  prefers the wrong composition;
* ``drift``: even started at the truth the fit leaves 1 %.

With ``--clean`` each CPI's two fits are also refitted on the target's own echo (the
flight emulated again with nothing recorded but the target: no clutter, phase noise,
thermal noise or artifacts), which splits the likelihood class by what decides it:

* ``noise``: on the echo alone the truth start's optimum is the better one (by more than
  ``--margin`` noise variances of the recorded CPI): the background chose the wrong fit;
* ``model``: on the echo alone the chosen fit still wins: the harmonic-chirp model
  misses something of the emulated echo that the wrong composition absorbs;
* ``tie``: the two optima cost the same on the echo alone (mostly the fit itself is
  within 1 % before a spare rotor joins a line: the spare's line is what is wrong).

With ``--white K`` (and ``--clean``) every tail CPI whose truth-started fit on the echo
is within 1 % is drawn again K times with the model exact and the background white:
the truth-started optimum's model of the echo plus complex white noise at the recorded
CPI's residual level (seeded by the flight's seed and the CPI). Each draw is fitted
from the truth's parameters and from the chosen composition's; it *flips* where a
chosen-composition fit costs less and its mean speed (before a spare joins a line) is
off by over 1 %. The expected share of flipped CPIs is a floor for any estimator that
decides by this likelihood (a lower bound: only the rivals the estimator found are
tried).

With ``--parts`` (and ``--clean``) each noise-class CPI is refitted, from both fits, on
the recording without one part of the background at a time (static clutter, wind-blown
clutter, phase noise, thermal noise, artifacts; every other part the same realisation):
a part *tips* the CPI where without it the truth-started fit wins by over ``--margin``.

``min-cost`` is the estimator that takes, per CPI, whichever of the chosen and the
truth-started fits has the lower cost: an upper bound for any search of this
likelihood (it knows the truth as a start, but must still win on cost). Shares within
1 % carry 95 % flight-bootstrap intervals; differences are paired.

    .venv/bin/python benchmarks/bound_rotorspeed.py --seed 1 --per-model 12 --workers 2
    .venv/bin/python benchmarks/bound_rotorspeed.py --seed 1 --clean      # + the echo-alone refits
    .venv/bin/python benchmarks/bound_rotorspeed.py --seed 1 --clean --white 20 --json b1.json
    .venv/bin/python benchmarks/bound_rotorspeed.py --seed 1 --clean --parts --json b1p.json
    .venv/bin/python benchmarks/bound_rotorspeed.py --from-json b1.json b3.json b4.json   # pooled
"""

from __future__ import annotations

import argparse
import ast
import functools
import json
import time
from dataclasses import replace
from multiprocessing import Pool

import numpy as np
from scipy.signal.windows import blackmanharris

import microdoppler.emulator.world as world
import microdoppler.rotors.fit as rf
import microdoppler.rotors.speed as rs
from microdoppler.stats.bootstrap import draw_flights, interval, ratio_replicates
from microdoppler.emulator.world import emulate_flight

import eval_rotorspeed as ev

_LAST: dict = {}


class _Recorded(rf._Model):
    """The fit's model, remembering its last fit (the chosen one: ``refine_cpi`` ends
    with ``fit(p, N, iterations=0)`` at the chosen parameters)."""

    def fit(self, p, N, iterations=None):
        p2, cost = super().fit(p, N, iterations)
        _LAST["fit"] = (self, p2.copy(), float(cost), N)
        return p2, cost


def _install_recorder(records: list) -> None:
    rf._Model = _Recorded
    orig = rf.refine_cpi

    def hooked(x, prf, n_blades, n_motors, **kw):
        res = orig(x, prf, n_blades, n_motors, **kw)
        if res is not None:
            F, p, cost, N = _LAST["fit"]
            records.append({"x": x, "F": F, "p": p, "cost": cost, "N": N, "res": res, "kw": kw})
        return res

    rs.refine_cpi = hooked


def _truth(flight, start: int, n_fft: int, M: int):
    """True speeds [rev/s] (``eval_rotorspeed``'s truth) and rates [rev/s^2] (the
    window^2-weighted slope) per rotor over the CPI starting at pulse ``start``."""
    prf = float(flight.prf_hz)
    tc = (start + n_fft / 2) / prf
    f = ev.true_cpi_speeds(flight, np.array([tc]), n_fft)[0]
    w = blackmanharris(n_fft, sym=False) ** 2
    k = np.linspace(0, n_fft - 1, 256).astype(int)
    wk = w[k] / w[k].sum()
    tt = (k - n_fft / 2) / prf
    tt = tt - np.sum(wk * tt)
    rev = flight.motors_rpm.astype(np.float64) / 60.0
    g = np.array(
        [np.sum(wk * tt * np.interp(tc + tt, flight.motors_time_s, rev[:, m])) / np.sum(wk * tt**2) for m in range(M)]
    )
    return f, g


def _recorded(spec, parts) -> np.ndarray:
    """The flight emulated again (same seeds, so the same target and the same
    realisation of every part) with only ``parts`` of the background recorded
    (:func:`microdoppler.emulator.background.record`'s ``parts``)."""
    orig = world.bg.record
    world.bg.record = functools.partial(orig, parts=frozenset(parts))
    try:
        return np.asarray(emulate_flight(spec)[0].iq)
    finally:
        world.bg.record = orig


def _echo_only(spec) -> np.ndarray:
    """The flight's target echo alone: no clutter, phase noise, noise or artifacts."""
    return _recorded(replace(spec, with_background=False), ())


def _white_flips(G, p_chosen, p_echo_chosen, q_echo, cost, n_draws: int, seed, tm: float, N: int):
    """The CPI again, with the model exact and the background white: the truth-started
    optimum's model of the echo alone (``G`` left at ``q_echo``) plus complex white noise
    at the recorded CPI's residual level (its chosen fit's ``cost``), ``n_draws`` times.
    Each draw is fitted from the truth's parameters and from the chosen composition's
    (recorded and echo-alone); a draw *flips* where a chosen-composition fit costs less
    than the truth-started one and its mean speed (before a spare joins a line) is off
    by over 1 %. Returns the share of draws that flip."""
    xm = (G.A @ G.c) / G.w  # the model's echo, unweighted (every column carries the window)
    sigma = np.sqrt(cost / (2.0 * np.sum(G.w**2)))  # per real part, unweighted
    rng = np.random.default_rng(seed)
    flips = 0
    for _ in range(n_draws):
        xs = xm + sigma * (rng.standard_normal(len(xm)) + 1j * rng.standard_normal(len(xm)))
        H = rf._Model(xs, 1.0 / (G.tt[1] - G.tt[0]), G.B, G.M, G.cfg)
        H.g0, H.s2 = G.g0, G.s2
        _, ct = H.fit(q_echo.copy(), N)
        wrong = [H.fit(s.copy(), N) for s in (p_chosen, p_echo_chosen)]
        pw, cw = min(wrong, key=lambda a: a[1])
        flips += int(cw < ct and abs(pw[2 : 2 + G.M].mean() / tm - 1) > 0.01)
    return flips / n_draws


def fit_config(fit: dict) -> rf.FitConfig:
    """The estimator's :class:`~microdoppler.rotors.fit.FitConfig` with ``fit``'s fields
    set (``--fit``): a field's name, or its former module constant's upper-case name
    (``KEEP``, ``MOVE_PASSES``: the fit's fixed settings are fields now)."""
    known = list(rf.FitConfig.__dataclass_fields__)
    fields = {}
    for k, v in fit.items():
        name = k.lower() if k.isupper() else k
        if name not in known:
            raise ValueError(f"--fit {k}=...: not a FitConfig field (one of: {', '.join(known)})")
        fields[name] = tuple(v) if isinstance(v, list) else v
    return replace(rf.FitConfig(), **fields)


def evaluate(spec, margin: float, fit: dict, clean: bool = False, white: int = 0, parts: bool = False) -> dict:
    records: list = []
    _install_recorder(records)
    flight, _ = emulate_flight(spec)
    echo = _echo_only(spec) if clean else None
    without: dict = {}  # part -> the recording without it, emulated when first needed
    cfg = fit_config(fit)
    est = rs.estimate_rotor_speeds(flight, config=rs.RotorSpeedConfig(fit=cfg))
    out = {"flight": spec.flight_id, "cpis": []}
    if not est.ok:
        return out
    iq = np.asarray(flight.iq)
    M, n_fft = est.n_motors, est.n_fft
    for rec in records:
        if rec["kw"].get("n_pairs", 0) < 2:
            continue
        x, F, p, cost = rec["x"], rec["F"], rec["p"], rec["cost"]
        start = int((x.ctypes.data - iq.ctypes.data) // iq.itemsize) if np.shares_memory(x, iq) else -1
        if start < 0:
            continue
        f_true, g_true = _truth(flight, start, n_fft, M)
        F.fit(p, rec["N"], iterations=0)
        pow_chosen = F.power.copy()
        tm = float(f_true.mean())
        pt = np.r_[p[0], p[1], f_true, g_true]
        q = pt
        for N in cfg.harmonics:
            q, cost_t = F.fit(q, N)
        noise = cost / (2 * len(x))  # residual variance per real sample at the chosen fit
        extra = {}
        if echo is not None:
            G = rf._Model(echo[start : start + n_fft], float(flight.prf_hz), est.n_blades, M, cfg)
            G.g0, G.s2 = F.g0, F.s2  # the same rate prior as the recorded CPI's fit
            pc, cc = G.fit(p.copy(), rec["N"])
            pq, cq = G.fit(q.copy(), rec["N"])
            extra = {
                "clean_dcost": float((cc - cq) / noise),
                "clean_err": float(pc[2 : 2 + M].mean() / tm - 1),
                "clean_err_truth_fit": float(pq[2 : 2 + M].mean() / tm - 1),
            }
            err = float(rec["res"].speeds_rev_s.mean() / tm - 1)
            noise_class = (
                abs(err) > 0.01
                and abs(q[2 : 2 + M].mean() / tm - 1) <= 0.01
                and (cost - cost_t) / noise <= margin
                and extra["clean_dcost"] > margin
            )
            if parts and noise_class:
                extra["without"] = {}
                for part in sorted(world.bg.PARTS):
                    if part not in without:
                        without[part] = _recorded(spec, world.bg.PARTS - {part})
                    H = rf._Model(without[part][start : start + n_fft], float(flight.prf_hz), est.n_blades, M, cfg)
                    H.g0, H.s2 = F.g0, F.s2
                    ch, qh = H.fit(p.copy(), rec["N"])[1], H.fit(q.copy(), rec["N"])[1]
                    extra["without"][part] = float((ch - qh) / noise)  # > margin: the truth wins without it
            if white and abs(err) > 0.01 and abs(pq[2 : 2 + M].mean() / tm - 1) <= 0.01:
                extra["white_flip"] = _white_flips(G, p, pc, pq, cost, white, [spec.seed, start, 2027], tm, rec["N"])
        out["cpis"].append(
            {
                "err": float(rec["res"].speeds_rev_s.mean() / tm - 1),
                "z": float((rec["res"].speeds_rev_s.mean() - tm) / rec["res"].mean_std_rev_s),
                "err_truth_fit": float(q[2 : 2 + M].mean() / tm - 1),
                "err_fit": float(p[2 : 2 + M].mean() / tm - 1),  # the chosen fit before a spare joins a line
                "dcost": float((cost - cost_t) / noise),  # > 0: the truth start fits better
                "balance": float(rec["res"].balance),
                "start": rec["res"].start,
                "n_pairs": int(rec["kw"]["n_pairs"]),
                # in bins at n = 1 from the true mean: the truth, the chosen fit (before a
                # spare joins a line), the truth-started fit, the periodogram's lines
                "bins": {
                    k: ((np.asarray(v, float) - tm) * est.n_blades * n_fft / flight.prf_hz).round(2).tolist()
                    for k, v in (
                        ("true", f_true),
                        ("fit", p[2 : 2 + M]),
                        ("truth_fit", q[2 : 2 + M]),
                        ("lines", rec["kw"]["lines_rev_s"]),
                    )
                },
                "power_db": (10 * np.log10(np.maximum(pow_chosen, 1e-30) / pow_chosen.max())).round(1).tolist(),
                **extra,
            }
        )
    return out


def _share(rows, pick, draws):
    num = np.array([float(sum(pick(c) for c in r["cpis"])) for r in rows])
    den = np.array([float(len(r["cpis"])) for r in rows])
    reps = ratio_replicates(num, den, draws)
    return num.sum() / den.sum(), reps


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-model", type=int, default=12)
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--margin", type=float, default=1.0, help="noise variances a cost must win by (default 1)")
    ap.add_argument("--json", default=None)
    ap.add_argument(
        "--clean",
        action="store_true",
        help="also refit each CPI on the target's echo alone (splits the likelihood class)",
    )
    ap.add_argument(
        "--white",
        type=int,
        default=0,
        metavar="K",
        help="with --clean: each tail CPI redrawn K times with the model exact and the background "
        "white at the recorded level (how often the likelihood itself flips)",
    )
    ap.add_argument(
        "--parts",
        action="store_true",
        help="with --clean: refit each noise-class CPI on the recording without each part of the "
        "background in turn (which part tips it)",
    )
    ap.add_argument(
        "--fit",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a field of microdoppler.rotors.fit.FitConfig for the estimator's fit (repeatable; the "
        "former upper-case constants' names still work), e.g. --fit keep=3, --fit move_passes=0, "
        "--fit move_rel=0.2",
    )
    ap.add_argument(
        "--from-json",
        nargs="+",
        default=None,
        metavar="JSON",
        help="summarise saved --json records (several: pooled) instead of running",
    )
    args = ap.parse_args(argv)
    if (args.white or args.parts) and not args.clean:
        ap.error("--white and --parts need --clean (they build on the echo-alone refits)")
    t0 = time.perf_counter()
    if args.from_json:
        rows, seeds, whites = [], [], []
        for fn in args.from_json:
            with open(fn) as fh:
                saved = json.load(fh)
            seeds.append(str(saved["args"]["seed"]))
            whites.append(int(saved["args"].get("white", 0)))
            rows += [{**r, "flight": f"{seeds[-1]}:{r['flight']}"} for r in saved["flights"]]
        args.seed, args.white = ",".join(seeds), max(whites)
    else:
        specs = ev.flight_specs(np.random.default_rng([args.seed, 4242]), args.per_model, args.duration)
        with Pool(args.workers) as pool:
            fit = {k: ast.literal_eval(v) for k, v in (a.split("=", 1) for a in args.fit)}
            fit_config(fit)  # a wrong name or value fails here, before the workers start
            rows = pool.starmap(evaluate, [(s, args.margin, fit, args.clean, args.white, args.parts) for s in specs])
    rows = [r for r in rows if r["cpis"]]
    draws = draw_flights([r["flight"] for r in rows], seed=0)
    m = args.margin
    within = lambda e: abs(e) <= 0.01  # noqa: E731
    mincost = lambda c: within(c["err_truth_fit"] if c["dcost"] > m else c["err"])  # noqa: E731
    a, ra = _share(rows, lambda c: within(c["err"]), draws)
    b, rb = _share(rows, mincost, draws)
    cps = [c for r in rows for c in r["cpis"]]
    tail = [c for c in cps if not within(c["err"])]
    search = [c for c in tail if within(c["err_truth_fit"]) and c["dcost"] > m]
    like = [c for c in tail if within(c["err_truth_fit"]) and c["dcost"] <= m]
    drift = [c for c in tail if not within(c["err_truth_fit"])]
    print(f"seed {args.seed}: {len(rows)} flights, {len(cps)} CPIs with >= 2 pairs, {time.perf_counter() - t0:.0f} s")
    print(
        f"within 1 %: the fit {100 * a:.1f} % [{100 * interval(ra)[0]:.1f}, {100 * interval(ra)[1]:.1f}]; "
        f"min-cost with the truth start {100 * b:.1f} % [{100 * interval(rb)[0]:.1f}, {100 * interval(rb)[1]:.1f}]; "
        f"difference {100 * (b - a):+.1f} [{100 * interval(rb - ra)[0]:+.1f}, {100 * interval(rb - ra)[1]:+.1f}] points"
    )
    print(f"tail {len(tail)} CPIs: search {len(search)}, likelihood {len(like)}, drift {len(drift)}")
    if like:
        d = np.array([c["dcost"] for c in like])
        print(
            f"  likelihood: the chosen fit's cost below the truth start's by median {np.median(-d):.1f} "
            f"noise variances (p10 {np.percentile(-d, 10):.1f}, p90 {np.percentile(-d, 90):.1f})"
        )
    if like and "clean_dcost" in like[0]:
        noise_ = [c for c in like if c["clean_dcost"] > m]
        model = [c for c in like if c["clean_dcost"] < -m]
        tie = [c for c in like if abs(c["clean_dcost"]) <= m]
        print(
            f"  likelihood, on the echo alone: noise {len(noise_)}, model {len(model)}, tie {len(tie)} "
            f"(of the ties, the fit within 1 % before a spare joins a line: "
            f"{sum(within(c['err_fit']) for c in tie)})"
        )
        if model:
            d = np.array([-c["clean_dcost"] for c in model])
            print(
                f"  model: the chosen fit's cost on the echo alone below the truth start's by median "
                f"{np.median(d):.1f} noise variances (max {d.max():.0f})"
            )
    split = [c for c in cps if "without" in c]
    if split:
        by: dict = {}
        for c in split:
            lifted = [k for k, v in sorted(c["without"].items()) if v > m]
            key = "+".join(lifted) if lifted else "no single part"
            by[key] = by.get(key, 0) + 1
        print(
            "  noise class, the part whose removal turns the cost to the truth: "
            + ", ".join(f"{k} {v}" for k, v in sorted(by.items(), key=lambda kv: -kv[1]))
        )
    tested = [c for c in cps if "white_flip" in c]
    if tested:
        e, re_ = _share(rows, lambda c: c.get("white_flip", 0.0), draws)
        print(
            f"  white background, model exact ({args.white} draws per tail CPI, {len(tested)} tested): "
            f"the likelihood flips to the chosen composition in {100 * e:.2f} % "
            f"[{100 * interval(re_)[0]:.2f}, {100 * interval(re_)[1]:.2f}] of all CPIs "
            f"(expected; {sum(c['white_flip'] > 0 for c in tested)} CPIs flip at least once)"
        )
        cls = lambda c: (
            "search"
            if c["dcost"] > m
            else "noise"
            if c["clean_dcost"] > m  # noqa: E731
            else "model"
            if c["clean_dcost"] < -m
            else "tie"
        )
        for name in ("search", "noise", "model", "tie"):
            g = [c["white_flip"] for c in tested if cls(c) == name]
            if g:
                print(
                    f"    {name}: {len(g)} CPIs, mean flip share {np.mean(g):.2f}, {sum(x > 0 for x in g)} flip "
                    f"at least once"
                )
    fine = [c for c in cps if within(c["err"])]
    print(
        f"  CPIs within 1 %: the truth start fits better by > {m:g} in {sum(c['dcost'] > m for c in fine)} "
        f"of {len(fine)}; stays within 1 % in {sum(within(c['err_truth_fit']) for c in fine)}"
    )
    if not args.from_json:
        ev.write_json(args, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
