"""Diagnosis of one measured drone flight: which catalog cause the paper's model misses.

:func:`diagnose_flight` measures the flight against the paper's model of it
(:mod:`.measure`), calibrates S_body, S_blade and alpha, runs one held-out
likelihood test per cause (:mod:`.causes`) and returns the report entry of
``shared/formats/flight-zarr.md``.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from ..catalog import CATALOG
from ..errors import ConfigError, InputError
from ..flightzarr import atomic_file, read_flight
from ..motorlog import MotorLog
from . import causes as C
from .measure import measure


@dataclass(frozen=True)
class DiagnosisConfig:
    """Settings of the diagnosis (``diagnosis:`` section of the config).

    Parameters
    ----------
    n_fft : int
        CPI length [pulses] of the STFT the statistics are read from.
    alpha : float
        Family-wise false-alarm level of the held-out tests (Bonferroni over causes).
    block_cpis : int
        CPIs per block of the two alternating held-out folds.
    margin_* : float
        Relevance margins: a significant cause is named only if its fitted effect is
        at least this (about half the catalog's detectable size).
    model_floor_db : float
        Std [dB] of per-CPI power the paper's model is allowed to miss (beyond noise).
    """

    n_fft: int = 4096
    seed: int = 0
    alpha: float = 0.01
    block_cpis: int = 8
    artifact_floor_db: float = 3.0
    body_search_hz: float = 10.0
    body_half_hz: float = 9.0
    clutter_guard_hz: float = 15.0
    scale_min: float = 0.8
    scale_max: float = 1.25
    scale_step: float = 0.0025
    n_match_harmonics: int = 3
    min_match: float = 0.2
    n_harmonics: int = 5
    line_half_bins: int = 4
    raised_floor_db: float = 3.0
    min_pair_snr: float = 5.0
    model_floor_db: float = 0.5
    max_lag_s: float = 2.0
    lag_step_s: float = 0.01
    pn_inner_hz: float = 35.0
    pn_outer_hz: float = 95.0
    pn_nuisance_decay_hz: tuple = ()
    pn_smooth_cpis: int = 2
    pn_body_skirt_hz: float = 10.0
    pn_model_guard_db: float = -10.0
    pn_bin_step: int = 2
    pn_smooth_bins: int = 2
    pn_clutter_line_hz: float = 5.0
    pn_line_guard_frac: float = 0.3
    pn_body_guard_hz: float = 40.0
    body_smooth_cpis: int = 9
    margin_asymmetry_db: float = 1.5
    margin_std_db: float = 1.5
    margin_body_std_db: float = 2.0
    margin_lag_s: float = 0.15
    margin_scale: float = 0.025
    margin_floor_rise_db: float = 3.0
    figures: bool = True

    @classmethod
    def from_dict(cls, d: dict | None) -> "DiagnosisConfig":
        d = dict(d or {})
        names = {f.name for f in fields(cls)}
        for k in d:
            if k not in names:
                raise ConfigError("config", f"diagnosis.{k}", "unknown key", f"one of {sorted(names)}")
        return cls(**d)

    def __post_init__(self):
        if not 0 < self.alpha < 1:
            raise ValueError(f"alpha={self.alpha} must be in (0, 1)")
        if self.block_cpis < 1:
            raise ValueError(f"block_cpis={self.block_cpis} must be >= 1")
        if self.n_fft < 64:
            raise ValueError(f"n_fft={self.n_fft} must be >= 64")


def _calibrate(M, cfg) -> dict:
    """S_body, S_blade, alpha of the paper's model fitted to the measurement, and the
    per-harmonic blade gain used as the model's prediction."""
    w2 = float((M.stft.window ** 2).sum())
    n = len(M.stft.window)
    good = M.valid & (M.body_pow > 0)
    s_body = float(np.sqrt(np.median(M.body_pow[good]) / (n * w2))) if good.any() else float("nan")
    use = C.usable_pairs(M, cfg)
    gains = np.ones(len(M.harm))
    for k in range(len(M.harm)):
        mk = M.valid & M.pair_ok[:, k] & (M.model_h[:, k] > 0) & (M.up[:, k] + M.lo[:, k] > 0)
        if mk.sum():
            gains[k] = float(np.median((M.up[mk, k] + M.lo[mk, k]) / (2 * M.model_h[mk, k])))
    hbar = float(np.median(M.f_log_hz)) * M.info["n_blades"]
    ks = np.flatnonzero(use & (gains > 0))
    if len(ks) >= 2:
        slope, icpt = np.polyfit(M.harm[ks] * hbar, 10 * np.log10(gains[ks]), 1)
        alpha = max(0.0, -slope / (20 * np.log10(np.e)))
        s_blade = float(10 ** (icpt / 20))
    elif len(ks) == 1:
        alpha, s_blade = 0.0, float(np.sqrt(gains[ks[0]]))
    else:
        alpha, s_blade = float("nan"), float("nan")
    if not np.isfinite(s_blade):
        s_blade = float(np.sqrt(np.median(gains)))
        alpha = 0.0 if not np.isfinite(alpha) else alpha
    ref = max(s_body, 1e-30)
    per_h_err = {}
    for k in ks:
        pred = s_blade ** 2 * np.exp(-2 * alpha * M.harm[k] * hbar)
        per_h_err[f"h{int(M.harm[k])}"] = round(float(10 * np.log10(gains[k] / pred)), 2)
    return {"s_body": 1.0, "s_blade": s_blade / ref, "alpha_s": float(alpha), "blade_gain": gains,
            "blade_abs": s_blade,
            "per_harmonic_power_error_db": per_h_err, "n_usable_harmonics": int(len(ks))}


def flight_log(flight, motor_log: MotorLog | None) -> MotorLog | None:
    if motor_log is not None:
        return motor_log
    if flight.has_motor_log:
        return MotorLog(flight.motors_time_s, flight.motors_rpm, str(flight.flight_id))
    return None


def run_tests(flight, motor_log: MotorLog, cfg: DiagnosisConfig):
    """Measurements, calibration and every cause's :class:`~.causes.CauseTest`."""
    M = measure(flight, motor_log, cfg)
    calib = _calibrate(M, cfg)
    fold = C.folds(len(M.t_s), cfg.block_cpis)
    lag, sc = C.test_log(M, cfg, fold)
    tests = {
        "sideband_asymmetry": C.test_asymmetry(M, cfg, fold),
        "sideband_fading": C.test_fading(M, cfg, fold, calib),
        "body_fluctuation": C.test_body(M, cfg, fold),
        "motor_log_lag": lag,
        "motor_speed_scale": sc,
        "phase_noise": C.test_phase_noise(M, cfg, fold, calib),
    }
    return M, calib, tests


def decide(tests: dict, cfg: DiagnosisConfig) -> tuple[str, float]:
    """The named cause and the e-value threshold (log)."""
    n = sum(t.testable for t in tests.values())
    thr = float(np.log(max(n, 1) / cfg.alpha))
    cands = [t for t in tests.values() if t.testable and t.log_e >= thr and t.relevant]
    if not cands:
        return "none", thr
    # strongest: the largest held-out log-likelihood ratio per scored observation (the
    # statistics differ in size: per-CPI values vs. periodogram ordinates)
    return max(cands, key=lambda t: t.log_e / max(t.n_obs, 1)).cause, thr


def _r(x, nd=4):
    if isinstance(x, dict):
        return {k: _r(v, nd) for k, v in x.items()}
    if isinstance(x, (float, np.floating)):
        return round(float(x), nd) if np.isfinite(x) else None
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def diagnose_flight(flight, *, motor_log: MotorLog | None = None, config=None, figure_path=None) -> dict:
    """Diagnose one measured drone flight.

    Parameters
    ----------
    flight : microdoppler.flightzarr.Flight
        A measured drone flight (``target == "drone"``).
    motor_log : MotorLog, optional
        Its motor log; default the store's ``motors/*`` arrays.
    config : DiagnosisConfig or dict, optional
    figure_path : path, optional
        Where to write the figure (measured vs baseline vs extended, residual).

    Returns
    -------
    dict
        The report entry: flight_id, cause, extension, gain, evidence.
    """
    cfg = config if isinstance(config, DiagnosisConfig) else DiagnosisConfig.from_dict(config)
    t0 = time.perf_counter()
    fid = flight.flight_id
    if flight.attrs.get("target") != "drone":
        raise InputError(fid, "attrs.target", f"is {flight.attrs.get('target')!r}", "'drone' (only drones are diagnosed)")
    log = flight_log(flight, motor_log)
    if log is None:
        raise InputError(fid, "motors", "no motor log", "motors/time_s + motors/rpm or a motor log")
    if len(flight.iq) < 4 * cfg.n_fft:
        raise InputError(fid, "iq", f"has {len(flight.iq)} pulses", f">= {4 * cfg.n_fft} (4 CPIs)")
    M, calib, tests = run_tests(flight, log, cfg)
    cause, thr = decide(tests, cfg)
    ordered = sorted((t for t in tests.values() if t.testable), key=lambda t: -t.log_e)
    top = tests[cause] if cause != "none" else (ordered[0] if ordered else None)
    evidence = {
        "log_evalue_threshold": thr,
        "calibration": {"s_body": calib["s_body"], "s_blade": calib["s_blade"], "alpha_s": calib["alpha_s"]},
        "per_harmonic_power_error_db": calib["per_harmonic_power_error_db"],
        "tests": {c: {"log_evalue": t.log_e, "n_heldout_obs": t.n_obs, "significant": bool(t.testable and t.log_e >= thr),
                      "relevant": bool(t.relevant), "testable": bool(t.testable), "params": t.params,
                      "statistic": t.statistic, **t.evidence}
                  for c, t in tests.items()},
        "n_cpis": int(len(M.t_s)), "n_valid_cpis": int(M.valid.sum()),
        "motor_log_speed_hz": float(np.median(M.f_log_hz)),
        "seconds": time.perf_counter() - t0,
    }
    if cause == "none":
        ext = None
    else:
        ext = {"name": cause, "params": {k: float(v) for k, v in tests[cause].params.items()}}
    gain = {"metric": f"heldout_nll_per_obs:{top.statistic if top else 'none'}",
            "baseline": top.nll_base if top else None,
            "extended": (top.nll_ext if cause != "none" else top.nll_base) if top else None,
            "held_out": True}
    entry = {"flight_id": fid, "cause": cause, "extension": ext, "gain": gain, "evidence": evidence}
    entry = _r(entry)
    if figure_path is not None and cfg.figures:
        from .figure import plot_diagnosis

        plot_diagnosis(flight, log, M, calib, tests, cause, figure_path, cfg)
    return entry


def write_json(obj, path) -> Path:
    """Write ``obj`` as JSON, atomically (:func:`flightzarr.atomic_file`)."""
    with atomic_file(path) as tmp:
        tmp.write_text(json.dumps(obj, indent=1))
    return Path(path)


def diagnose(paths, out_json, *, motor_logs: dict | None = None, config=None, figures_dir=None,
             log=print) -> dict:
    """Diagnose the drone flights at ``paths`` and write the report JSON.

    Flights that are not drones or have no motor log are skipped (logged).
    ``motor_logs`` maps flight_id -> MotorLog (overrides the stores' own logs).
    """
    cfg = config if isinstance(config, DiagnosisConfig) else DiagnosisConfig.from_dict(config)
    entries = []
    for p in paths:
        f = read_flight(p)
        ml = (motor_logs or {}).get(f.flight_id)
        if f.attrs.get("target") != "drone":
            log(f"skip {f.flight_id}: target {f.attrs.get('target')}")
            continue
        if ml is None and not f.has_motor_log:
            log(f"skip {f.flight_id}: no motor log")
            continue
        fig = Path(figures_dir) / f"{f.flight_id}.png" if figures_dir else None
        e = diagnose_flight(f, motor_log=ml, config=cfg, figure_path=fig)
        log(f"{f.flight_id}: {e['cause']} {e['extension']['params'] if e['extension'] else ''} "
            f"({e['evidence']['seconds']:.1f} s)")
        entries.append(e)
    report = {"catalog": list(CATALOG), "flights": entries}
    write_json(report, out_json)
    return report
