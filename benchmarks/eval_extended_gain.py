"""What the `extended` twins gain over `sub_cpi`, on flights with known causes (not in CI).

Issue 12 §4 asks that a twin carrying its own flight's diagnosed causes be closer to
its measured flight on the features of those causes, and no worse elsewhere. In the
default world each cause occurs on one or two training flights, too few to show it;
this benchmark measures it with power.

Flights are planned as in ``eval_diagnosis.py`` (the same plan function: one-cause,
two-cause and clean flights, half from the emulator and half from the independent
generator ``tests/independent_generator.py``, parameters drawn from a seed the
diagnosis never sees, neutral shuffled ids), at body SNR >= 36 dB. For each flight:

1. the diagnosis sees the flight only and names its causes (``diagnosis-report/2``);
2. the `sub_cpi` twin is fitted to the flight as the pipeline does (``fit_twin``:
   calibration on fold A of the CPIs, alternating blocks of 8);
3. the `extended` twin carries the diagnosed causes with their fitted parameters
   (``ExtensionSet``: lag and scale correct the log that drives the blades, the
   others act in the synthesis), same seed, same calibration;
4. both twins, injected into the flight's background, are compared with the measured
   flight on fold B only (``microdoppler.datasets.fidelity.distances``, Table VI's features).

Reported per feature: mean distance of each variant and the paired difference
``extended - sub_cpi`` with a 95 % flight-bootstrap interval
(``microdoppler.stats.bootstrap``), over the flights whose *true* causes include the cause
the feature measures, and over the flights without it. From the repository root::

    .venv/bin/python benchmarks/eval_extended_gain.py --seed 20261124 --flights-per-cause 8 \\
        --two-cause 16 --clean 8 --workers 2 --json gain.json --markdown gain.md
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from eval_diagnosis import HIGH_SNR_DB, _make, _snr_db, make_plan  # noqa: E402

from microdoppler.stats.bootstrap import draw_flights, interval, ratio_replicates, resolved  # noqa: E402
from microdoppler.datasets.calibration import CalibrationConfig, fit_twin  # noqa: E402
from microdoppler.datasets.extended import catalog_params  # noqa: E402
from microdoppler.datasets.injection import inject  # noqa: E402
from microdoppler.datasets.speeds import resample_flight  # noqa: E402
from microdoppler.diagnosis import Undiagnosable, diagnose_flight  # noqa: E402
from microdoppler.diagnosis.measure import flight_log  # noqa: E402
from microdoppler.causes.extensions import ExtensionSet  # noqa: E402
from microdoppler.datasets.fidelity import DISTANCES, distances, flight_features, scoring_mask  # noqa: E402
from microdoppler.io.outputs import atomic_file  # noqa: E402
from microdoppler.causes.catalog import UNEXPLAINED  # noqa: E402
from microdoppler.spectra.spectrogram import SpectrogramConfig  # noqa: E402

#: the Table VI features each cause should move (the "features of the diagnosed cause")
CAUSE_FEATURES = {
    "sideband_asymmetry": ["asymmetry_db"],
    "sideband_fading": ["blade_std_db", "blade_timescale_s"],
    "body_fluctuation": ["body_std_db"],
    "motor_log_lag": ["line_hz"],
    "motor_speed_scale": ["line_hz"],
    "phase_noise": ["floor_db"],
    "blade_imbalance": ["nonmultiple_db"],
}
#: the pipeline's sub_cpi settings (config/config.yaml: sampling.per_variant.sub_cpi)
SUB_CPI = {"per_cpi": 8, "window_pulses_min": 1500, "window_pulses_max": 3000}


def evaluate_flight(p: dict) -> dict:
    """Make, diagnose, twin twice, score (see the module doc)."""
    t0 = time.perf_counter()
    nominal = p["target_snr_db"] + (3.0 if p["generator"] == "emulator" else 1.0)
    for _ in range(3):
        flight = _make(p, nominal)
        snr = _snr_db(flight)
        if snr >= HIGH_SNR_DB:
            break
        nominal += p["target_snr_db"] - snr + 0.5
    row = {k: p[k] for k in ("flight_id", "kind", "generator", "radar", "effects")}
    row.update(true=sorted(p["effects"]), snr_db=round(snr, 2))
    try:
        e = diagnose_flight(flight, config={"figures": False})
        named = {
            c["cause"]: catalog_params(c["cause"], (c.get("extension") or {}).get("params"))
            for c in e["causes"]
            if c["cause"] != UNEXPLAINED
        }  # a goodness of fit: no extension
    except Undiagnosable as exc:
        row.update(named=[], reason=f"skipped: {exc.reason}")
        return row
    row["named"] = sorted(named)
    ml = flight_log(flight, None)
    spec_cfg, cfg = SpectrogramConfig(), CalibrationConfig()
    seed = p["seed"] & 0x7FFFFFFF
    n, prf = len(flight.iq), flight.prf_hz
    model = flight.attrs.get("drone_model", "")
    ext = ExtensionSet(named)
    measured = flight_features(flight, flight.iq, ml, spec_cfg=spec_cfg)
    out = {}
    for variant in ("sub_cpi", "extended"):
        use = ext if variant == "extended" else ExtensionSet({})
        rev, _ = resample_flight(
            "sub_cpi", use.transform_log(ml), n, prf, model, settings=SUB_CPI, n_fft=spec_cfg.n_fft, seed=seed
        )
        kw = {}
        if use.effects:
            # as the pipeline's extended twins (datasets.calibration): the synthesis's
            # extensions, the post-processing and each blade's amplitude (blade_imbalance)
            kw = dict(
                extensions=lambda s: use.model_extensions(prf_hz=prf, n_pulses=n, seed=s),
                post=lambda x: use.post(x, prf_hz=prf, seed=seed),
                blade_amplitudes=use.blade_amplitudes(int(flight.attrs["n_blades"])),
            )
        iq, res = fit_twin(flight, rev, use.transform_log(ml), spec_cfg=spec_cfg, cfg=cfg, seed=seed, **kw)
        injected = inject(iq, flight.background_iq, effects=dict(use.effects), prf_hz=prf, seed=seed)
        twin = flight_features(flight, injected, ml, spec_cfg=spec_cfg)
        mask, _ = scoring_mask(res, len(twin.time_s))
        out[variant] = {**distances(measured, twin, mask), "status": res["status"]}
    row.update(distances=out, seconds=round(time.perf_counter() - t0, 1))
    return row


def summarise(rows: list[dict], seed: int, n_boot: int) -> tuple[str, dict]:
    """Per cause and feature: sub_cpi and extended mean distance and extended - sub_cpi
    with flight-bootstrap CIs, on flights with and without the cause."""
    rows = [r for r in rows if "distances" in r]
    draws = draw_flights([r["flight_id"] for r in rows], n_boot=n_boot, seed=seed)
    lines = [
        "| cause | feature | flights | sub_cpi | extended | extended − sub_cpi [95 % CI] | resolved |",
        "|---|---|---|---|---|---|---|",
    ]
    out = {}

    def stat(v, m):
        v = np.where(m, np.nan_to_num(v), 0.0)
        lo, hi = interval(ratio_replicates(v, m.astype(float), draws))
        return float(v.sum() / m.sum()), lo, hi

    for cause, feats in CAUSE_FEATURES.items():
        has = np.array([cause in r["true"] for r in rows])
        for feat in feats:
            s = np.array([r["distances"]["sub_cpi"][feat] for r in rows], float)
            x = np.array([r["distances"]["extended"][feat] for r in rows], float)
            ok = np.isfinite(s) & np.isfinite(x)
            for label, m in (("with", has & ok), ("without", ~has & ok)):
                if m.sum() < 2:
                    continue
                a, b, d = stat(s, m), stat(x, m), stat(x - s, m)
                res = resolved(d[1], d[2])
                out[f"{cause} {feat} {label}"] = {
                    "n": int(m.sum()),
                    "sub_cpi": a,
                    "extended": b,
                    "diff": d,
                    "resolved": res,
                }
                lines.append(
                    f"| {cause} ({label}) | {feat} [{DISTANCES[feat]}] | {int(m.sum())} | {a[0]:.3g} | "
                    f"{b[0]:.3g} | {d[0]:+.3g} [{d[1]:+.3g}, {d[2]:+.3g}] | {'yes' if res else 'no'} |"
                )
    named_true = sum(len(set(r["named"]) & set(r["true"])) for r in rows)
    n_true = sum(len(r["true"]) for r in rows)
    spurious = sum(len(set(r["named"]) - set(r["true"])) for r in rows)
    lines += [
        "",
        f"{len(rows)} flights twinned; diagnosis named {named_true} of {n_true} true causes, "
        f"{spurious} spurious (the extended twins carry what was named, not the truth)",
    ]
    return "\n".join(lines), out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--flights-per-cause", type=int, default=8)
    ap.add_argument("--two-cause", type=int, default=16)
    ap.add_argument("--clean", type=int, default=8)
    ap.add_argument("--seed", type=int, required=True, help="seed of the plan")
    ap.add_argument("--duration-s", type=float, default=40.0, help="flight duration [s] (default 40)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--n-boot", type=int, default=2000)
    ap.add_argument("--json", default="")
    ap.add_argument("--markdown", default="")
    a = ap.parse_args(argv)
    if a.workers < 1 or min(a.flights_per_cause, a.two_cause, a.clean) < 0:
        ap.error("--workers must be >= 1 and the flight counts >= 0")
    plan = make_plan(a.seed, a.flights_per_cause, a.two_cause, a.clean, a.duration_s, high_share=1.0)
    print(f"{len(plan)} flights of {a.duration_s:g} s, seed {a.seed}, {a.workers} worker(s)", flush=True)
    t0 = time.time()
    if a.workers == 1:
        it = map(evaluate_flight, plan)
    else:
        import multiprocessing as mp

        pool = mp.get_context("fork").Pool(a.workers)
        it = pool.imap_unordered(evaluate_flight, plan)
    rows = []
    for r in it:
        rows.append(r)
        el = time.time() - t0
        d = r.get("distances", {})
        brief = (
            " ".join(f"{f}:{d['sub_cpi'][f]:.3g}->{d['extended'][f]:.3g}" for c in r["true"] for f in CAUSE_FEATURES[c])
            if d
            else r.get("reason", "")
        )
        print(
            f"[{len(rows)}/{len(plan)} {el:.0f} s] {r['flight_id']} {r['generator'][:3]} snr={r['snr_db']:.1f} "
            f"true={r['true']} named={r.get('named')} {brief}",
            flush=True,
        )
    if a.workers > 1:
        pool.close()
        pool.join()
    rows.sort(key=lambda r: r["flight_id"])
    text, out = summarise(rows, seed=a.seed ^ 0x6A1, n_boot=a.n_boot)
    text += (
        f"\n\n{len(plan)} flights, seed {a.seed}, {a.duration_s:g} s each; wall {time.time() - t0:.0f} s, "
        f"{a.workers} worker(s)"
    )
    print("\n" + text, flush=True)
    if a.json:
        with atomic_file(a.json) as tmp:
            tmp.write_text(
                json.dumps({"seed": a.seed, "args": vars(a), "rows": rows, "summary": out}, indent=1, default=float)
            )
    if a.markdown:
        with atomic_file(a.markdown) as tmp:
            tmp.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
