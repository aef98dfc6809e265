"""Twins built from rotor speeds estimated by the radar vs from the drone's own log.

    .venv/bin/python benchmarks/eval_radar_twins.py [--per-model 5] [--seed 1] [--duration-s 20]

For emulated Inspire 2 and Matrice 300 flights on both radars, builds the calibrated
``sub_cpi`` twin (microdoppler.datasets.calibration.fit_twin) three times: driven by the
flight's motor log (``log``), and by ``microdoppler.rotors.speed`` from the flight's own
HERM lines (as for a flight without a log), its rows either the instants whose spline
has the estimates as CPI means (``radar``, what the tool stores) or the CPI means
themselves (``radar_cpi_means``, before 2026-11-24). Fidelity terms per flight and twin:

- ``line_error_pct``: HERM line spacing of the twin (twin + background, measured with
  the same rotor-speed estimator) against the measured flight's, median over CPIs of
  |twin / measured - 1| [%];
- ``body_error_db``, ``sideband1_error_db``: the calibration's achieved minus measured
  SNR of the body and of the first sideband pair [dB];
- ``pairs_error``: visible sideband pairs, twin minus measured;
- Table VI's distances (``microdoppler.datasets.fidelity.distances``, prefixed ``vi_``: HERM
  line frequency [Hz], visible pairs, first-pair level, asymmetry, blade-power std and
  timescale, body-power std, floor), on the CPIs the calibration did not see, with
  the flight's own log placing the lines for every twin (the same ruler).

Prints per-flight rows, the mean over flights with a 95 % bootstrap interval (the
flight is the unit: microdoppler.stats.bootstrap) and the paired differences radar - log,
radar_cpi_means - log and radar - radar_cpi_means.
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

from microdoppler.stats.bootstrap import draw_flights, interval, ratio_replicates, resolved
from microdoppler.datasets.calibration import fit_twin
from microdoppler.emulator import FlightSpec, emulate_flight
from microdoppler.datasets.fidelity import DISTANCES, distances, flight_features, scoring_mask
from microdoppler.io.motorlog import MotorLog
from microdoppler.rotors.speed import estimate_rotor_speeds
from microdoppler.rotors.sampling import resample
from microdoppler.spectra.spectrogram import SpectrogramConfig

TERMS = ("line_error_pct", "body_error_db", "sideband1_error_db", "pairs_error", *(f"vi_{k}" for k in DISTANCES))


def _spacing(flight, iq):
    """Per-CPI mean rotor speed [rev/s] of ``iq`` read as the flight (NaN where none)."""
    from dataclasses import replace

    est = estimate_rotor_speeds(replace(flight, iq=iq))
    return est.common_rev_s if est.ok else np.full(len(est.time_s), np.nan)


def one_flight(spec: FlightSpec, spec_cfg: SpectrogramConfig) -> list[dict]:
    flight, _ = emulate_flight(spec)
    measured = _spacing(flight, flight.iq)
    est = estimate_rotor_speeds(flight)
    logs = {"log": MotorLog(flight.motors_time_s, flight.motors_rpm, "log")}
    if est.ok:
        logs["radar"] = est.to_motor_log()
        logs["radar_cpi_means"] = est.to_motor_log(cpi_means=True)
    rows = []
    measured_features = flight_features(flight, flight.iq, logs["log"], spec_cfg=spec_cfg)
    for source, log in logs.items():
        rev_s = resample("sub_cpi", log, len(flight.iq), flight.prf_hz)
        iq, res = fit_twin(flight, rev_s, log, spec_cfg=spec_cfg, seed=spec.seed)
        twin = _spacing(flight, iq + flight.background_iq)
        n = min(len(twin), len(measured))
        rel = np.abs(twin[:n] / measured[:n] - 1) * 100
        twin_features = flight_features(flight, iq + flight.background_iq, logs["log"], spec_cfg=spec_cfg)
        mask, _ = scoring_mask(res, len(twin_features.time_s))
        vi = distances(measured_features, twin_features, mask)
        rows.append(
            {
                "flight_id": spec.flight_id,
                "drone_model": spec.drone_model,
                "radar_id": spec.radar_id,
                "source": source,
                "status": res["status"],
                "line_error_pct": float(np.nanmedian(rel)) if np.isfinite(rel).any() else np.nan,
                "body_error_db": res["body_error_db"],
                "sideband1_error_db": res["sideband1_error_db"],
                "pairs_error": res["n_pairs_twin"] - res["n_pairs_measured"],
                **{f"vi_{k}": v for k, v in vi.items()},
            }
        )
    if not est.ok:
        rows.append(
            {
                "flight_id": spec.flight_id,
                "drone_model": spec.drone_model,
                "radar_id": spec.radar_id,
                "source": "radar",
                "status": f"no estimate: {est.reason}",
            }
        )
    return rows


PAIRS = (("radar", "log"), ("radar_cpi_means", "log"), ("radar", "radar_cpi_means"))


def summarise(df: pd.DataFrame, seed: int) -> pd.DataFrame:
    """Mean |term| per pair of sources with flight-bootstrap 95 % intervals, and their
    paired difference (:data:`PAIRS`)."""
    both = df.pivot_table(index="flight_id", columns="source", values=list(TERMS), aggfunc="first")
    both = both.dropna(subset=[(TERMS[0], s) for s in ("log", "radar", "radar_cpi_means")])
    draws = draw_flights(both.index, n_boot=2000, seed=seed)
    out = []
    ones = np.ones(len(both))
    for first, second in PAIRS:
        for t in TERMS:
            a = np.abs(both[(t, second)].to_numpy(float))
            b = np.abs(both[(t, first)].to_numpy(float))
            ra, rb = ratio_replicates(a, ones, draws), ratio_replicates(b, ones, draws)
            lo, hi = interval(rb - ra)
            out.append(
                {
                    "difference": f"{first} - {second}",
                    "term": f"|{t}|",
                    "second": a.mean(),
                    "second_ci95": interval(ra),
                    "first": b.mean(),
                    "first_ci95": interval(rb),
                    "first_minus_second": b.mean() - a.mean(),
                    "diff_ci95": (lo, hi),
                    "resolved": resolved(lo, hi),
                    "n_flights": len(both),
                }
            )
    return pd.DataFrame(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--per-model", type=int, default=5, help="flights per drone model (radars alternate)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--duration-s", type=float, default=20.0)
    a = p.parse_args(argv)
    rng = np.random.default_rng(a.seed)
    spec_cfg = SpectrogramConfig()
    rows = []
    for model in ("inspire2", "matrice300"):
        for k in range(a.per_model):
            spec = FlightSpec(
                f"{model[:3]}{k:02d}",
                "drone",
                drone_model=model,
                radar_id=("radar1", "radar2")[k % 2],
                duration_s=a.duration_s,
                mean_range_m=float(rng.uniform(800, 2500)),
                speed_mps=float(rng.uniform(3, 10)),
                snr_db=float(rng.uniform(38, 46)),
                seed=int(rng.integers(2**31)),
            )
            rows += one_flight(spec, spec_cfg)
            print(pd.DataFrame(rows[-3:]).round(4).to_string(index=False, header=len(rows) <= 3), flush=True)
    df = pd.DataFrame(rows)
    pd.set_option("display.width", 200)
    print()
    print(summarise(df, a.seed).round(3).to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
