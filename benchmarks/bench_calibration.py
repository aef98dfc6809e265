"""Twin calibration cost and faithfulness: the capped, linear-STFT fit vs the previous fit.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_calibration.py [--n-flights 6]
        [--duration-s 180] [--caps 64] [--old-rev 89148458dc1b] [--seed 3]

Emulates ``--n-flights`` Inspire 2 / Matrice 300 flights of ``--duration-s`` (paper
profile: median 174-203 s) and fits each flight's ``sub_cpi`` twin with the previous
``microdoppler.datasets.calibration`` (loaded from git revision ``--old-rev``) and
with the current one at each ``max_fit_cpis`` in ``--caps`` (0 = every fold-A CPI),
interleaved per flight (the order alternates between flights) so that machine load
hits both alike. Per flight and fit: wall time, alpha, S_body, S_blade, the achieved
body and first-sideband errors on every fold-A CPI (``fit_twin``'s check), visible
pairs, and the held-out (fold B) fidelity distances of ``microdoppler.datasets.fidelity``.

Prints per-flight rows and, per cap, the time ratio new/old (ratio of flight sums)
and the mean paired difference new - old of each term, each with a 95 % flight
bootstrap interval (``microdoppler.stats.bootstrap``: the flight is the unit).
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from microdoppler.datasets import fidelity
from microdoppler.stats.bootstrap import draw_flights, interval, ratio_replicates, resolved
from microdoppler.datasets import calibration as new
from microdoppler.emulator import FlightSpec, emulate_flight
from microdoppler.io.motorlog import MotorLog
from microdoppler.rotors.sampling import resample
from microdoppler.spectra.spectrogram import SpectrogramConfig

REPO = Path(__file__).resolve().parents[1]
MODULE = "src/microdoppler/datasets/calibration.py"
#: the calibration before the capped, linear-STFT fit
OLD_REV = "89148458dc1bfedf9d056750ba12f04345be9ca7"
TERMS = (
    "alpha_s",
    "log10_s_body",
    "log10_s_blade",
    "abs_body_error_db",
    "abs_sideband1_error_db",
    "pairs_error",
    "heldout_first_pair_db",
    "heldout_body_std_db",
    "heldout_n_pairs",
    "heldout_line_hz",
)


def load_old(rev: str):
    """The calibration module as of git revision ``rev`` (run inside the package)."""
    src = subprocess.run(
        ["git", "show", f"{rev}:{MODULE}"], cwd=REPO, capture_output=True, text=True, check=True
    ).stdout
    name = "microdoppler.datasets._calibration_old"
    spec = importlib.util.spec_from_loader(name, loader=None)
    mod = importlib.util.module_from_spec(spec)
    mod.__package__ = "microdoppler.datasets"
    sys.modules[name] = mod
    exec(compile(src, f"{rev[:12]}:{MODULE}", "exec"), mod.__dict__)
    return mod


def specs(n: int, duration_s: float, seed: int) -> list[FlightSpec]:
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        model = ("inspire2", "matrice300")[k % 2]
        radar = ("radar1", "radar2")[k // 2 % 2]
        out.append(
            FlightSpec(
                f"{model[:3]}{k:02d}",
                "drone",
                drone_model=model,
                radar_id=radar,
                duration_s=duration_s,
                mean_range_m=float(rng.uniform(800, 2500)),
                speed_mps=float(rng.uniform(3, 10)),
                snr_db=float(rng.uniform(38, 46)),
                seed=int(rng.integers(2**31)),
            )
        )
    return out


def heldout(flight, log, iq, res, spec_cfg, measured_features) -> dict:
    """Fidelity distances of the injected twin on the CPIs the fit did not see (fold B)."""
    twin = fidelity.flight_features(flight, iq + flight.background_iq, log, spec_cfg=spec_cfg)
    mask, held = fidelity.scoring_mask(res, len(twin.time_s))
    assert held, "no held-out CPIs"
    d = fidelity.distances(measured_features, twin, mask)
    return {f"heldout_{k}": d[k] for k in ("first_pair_db", "body_std_db", "n_pairs", "line_hz")}


def run_flight(spec: FlightSpec, fits: dict, spec_cfg: SpectrogramConfig, flip: bool) -> list[dict]:
    flight, _ = emulate_flight(spec)
    log = MotorLog(flight.motors_time_s, flight.motors_rpm, "log")
    rev_s = resample("sub_cpi", log, len(flight.iq), flight.prf_hz)
    meas = fidelity.flight_features(flight, flight.iq, log, spec_cfg=spec_cfg)
    rows = []
    for name in list(fits)[::-1] if flip else list(fits):
        fit, cfg = fits[name]
        t0 = time.perf_counter()
        iq, res = fit(flight, rev_s, log, spec_cfg=spec_cfg, cfg=cfg, seed=spec.seed)
        wall = time.perf_counter() - t0
        rows.append(
            {
                "flight_id": spec.flight_id,
                "drone_model": spec.drone_model,
                "fit": name,
                "wall_s": wall,
                "n_search_cpis": res.get("n_search_cpis", res["n_fit_cpis"]),
                "status": res["status"],
                "alpha_s": res["alpha_s"],
                "log10_s_body": np.log10(res["s_body"]),
                "log10_s_blade": np.log10(res["s_blade"]),
                "abs_body_error_db": abs(res["body_error_db"]),
                "abs_sideband1_error_db": abs(res["sideband1_error_db"]),
                "pairs_error": res["n_pairs_twin"] - res["n_pairs_measured"],
                **heldout(flight, log, iq, res, spec_cfg, meas),
            }
        )
    return rows


def summarise(df: pd.DataFrame, seed: int) -> pd.DataFrame:
    old = df[df.fit == "old"].set_index("flight_id")
    draws = draw_flights(old.index, n_boot=2000, seed=seed)
    ones = np.ones(len(old))
    out = []
    for name in [f for f in df.fit.unique() if f != "old"]:
        nw = df[df.fit == name].set_index("flight_id").loc[old.index]
        r = ratio_replicates(nw.wall_s.to_numpy(), old.wall_s.to_numpy(), draws)
        out.append(
            {
                "fit": name,
                "term": "wall_s new/old",
                "old": old.wall_s.mean(),
                "new": nw.wall_s.mean(),
                "diff_or_ratio": nw.wall_s.sum() / old.wall_s.sum(),
                "ci95": interval(r),
                "resolved": None,
            }
        )
        for t in TERMS:
            d = nw[t].to_numpy(float) - old[t].to_numpy(float)
            lo, hi = interval(ratio_replicates(d, ones, draws))
            out.append(
                {
                    "fit": name,
                    "term": f"{t} new-old",
                    "old": old[t].mean(),
                    "new": nw[t].mean(),
                    "diff_or_ratio": float(np.mean(d)),
                    "ci95": (lo, hi),
                    "resolved": resolved(lo, hi),
                }
            )
    return pd.DataFrame(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n-flights", type=int, default=6)
    p.add_argument("--duration-s", type=float, default=180.0)
    p.add_argument("--caps", type=int, nargs="+", default=[new.CalibrationConfig().max_fit_cpis])
    p.add_argument("--old-rev", default=OLD_REV)
    p.add_argument("--seed", type=int, default=3)
    a = p.parse_args(argv)
    old = load_old(a.old_rev)
    spec_cfg = SpectrogramConfig()
    fits = {"old": (old.fit_twin, old.CalibrationConfig())}
    for cap in a.caps:
        fits[f"new_cap{cap}"] = (new.fit_twin, replace(new.CalibrationConfig(), max_fit_cpis=cap))
    pd.set_option("display.width", 250)
    rows = []
    for k, s in enumerate(specs(a.n_flights, a.duration_s, a.seed)):
        rows += run_flight(s, fits, spec_cfg, flip=bool(k % 2))
        print(pd.DataFrame(rows[-len(fits) :]).round(4).to_string(index=False), flush=True)
    df = pd.DataFrame(rows)
    print()
    print(summarise(df, a.seed).round(4).to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
