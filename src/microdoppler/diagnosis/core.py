"""Diagnosis of one measured drone flight: which catalog causes the paper's model misses.

:func:`diagnose_flight` measures the flight against the paper's model of it
(:mod:`.measure`), calibrates S_body, S_blade and alpha, runs one held-out
likelihood test per cause (:mod:`.causes`), names every significant and relevant
cause greedily (:func:`decide_all`: each later cause tested with the named causes'
extensions in both models, at a step-wise Bonferroni threshold,
:func:`step_threshold`), re-tests each named cause with all the others in both
models (dropping one that no longer holds), measures each one's gain so, and
returns the report entry of
``shared/formats/flight-zarr.md`` (``diagnosis-report/2``). A flight it cannot judge
raises :class:`Undiagnosable` (an :class:`InputError` naming the field);
:func:`diagnose` lists such flights as ``skipped`` with the reason.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from ..synthesis.catalog import CATALOG
from ..errors import ConfigError, InputError
from ..io.flightzarr import read_flight
from ..io.outputs import atomic_file
from ..io.motorlog import MotorLog, check_motor_log
from . import causes as C
from .measure import measure


def _is_int(v) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _is_number(v) -> bool:
    return (_is_int(v) or isinstance(v, (float, np.floating))) and np.isfinite(float(v))


def _check_value(source, key: str, v, kind: str, lo=None, hi=None, lo_open=False, hi_open=False):
    """``v`` as the config value of ``diagnosis.<key>``: type ``kind`` (``int``,
    ``float``, ``bool``, ``floats``) within [lo, hi] (open ends with ``*_open``);
    else :class:`ConfigError` naming ``diagnosis.<key>``."""
    field = f"diagnosis.{key}"

    def rng_text():
        a = "" if lo is None else (f"> {lo:g}" if lo_open else f">= {lo:g}")
        b = "" if hi is None else (f"< {hi:g}" if hi_open else f"<= {hi:g}")
        if lo is not None and hi is not None:
            return f"in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
        return a or b

    def in_range(x):
        return ((lo is None or (x > lo if lo_open else x >= lo))
                and (hi is None or (x < hi if hi_open else x <= hi)))

    what = {"int": "an integer", "float": "a number", "floats": "a list of numbers", "bool": "true or false"}[kind]
    expected = f"{what} {rng_text()}".strip() if kind != "bool" else what
    if kind == "bool":
        if not isinstance(v, (bool, np.bool_)):
            raise ConfigError(source, field, f"is {v!r} ({type(v).__name__})", expected)
        return bool(v)
    if kind == "floats":
        if isinstance(v, (str, bytes, dict)) or not hasattr(v, "__iter__"):
            raise ConfigError(source, field, f"is {v!r} ({type(v).__name__})", expected)
        out = []
        for i, x in enumerate(v):
            if not _is_number(x) or not in_range(float(x)):
                raise ConfigError(source, f"{field}[{i}]", f"is {x!r}", expected)
            out.append(float(x))
        return tuple(out)
    ok_type = _is_int(v) if kind == "int" else _is_number(v)
    if not ok_type:
        if kind == "float" and isinstance(v, (float, np.floating)):
            raise ConfigError(source, field, f"is {v!r}", f"a finite number {rng_text()}".strip())
        raise ConfigError(source, field, f"is {v!r} ({type(v).__name__})", expected)
    x = int(v) if kind == "int" else float(v)
    if not in_range(x):
        raise ConfigError(source, field, f"is {x:g}", expected)
    return x


#: type and allowed range of every DiagnosisConfig field: (kind, lo, hi, lo_open, hi_open)
_RULES = {
    "n_fft": ("int", 64, None, False, False),
    "seed": ("int", 0, None, False, False),
    "alpha": ("float", 0, 1, True, True),
    "block_cpis": ("int", 1, None, False, False),
    "artifact_floor_db": ("float", 0, None, True, False),
    "body_search_hz": ("float", 0, None, True, False),
    "body_half_hz": ("float", 0, None, True, False),
    "clutter_guard_hz": ("float", 0, None, False, False),
    "scale_min": ("float", 0, 1, True, False),
    "scale_max": ("float", 1, None, False, False),
    "scale_step": ("float", 0, None, True, False),
    "n_match_harmonics": ("int", 1, None, False, False),
    "min_match": ("float", 0, 1, False, True),
    "n_harmonics": ("int", 1, None, False, False),
    "line_half_bins": ("int", 1, None, False, False),
    "raised_floor_db": ("float", 0, None, True, False),
    "min_pair_snr": ("float", 0, None, False, False),
    "model_floor_db": ("float", 0, None, False, False),
    "max_lag_s": ("float", 0, None, True, False),
    "lag_step_s": ("float", 0, None, True, False),
    "pn_inner_hz": ("float", 0, None, False, False),
    "pn_outer_hz": ("float", 0, None, True, False),
    "pn_nuisance_decay_hz": ("floats", 0, None, True, False),
    "pn_smooth_cpis": ("int", 0, None, False, False),
    "pn_body_skirt_hz": ("float", 0, None, True, False),
    "pn_model_guard_db": ("float", None, None, False, False),
    "pn_bin_step": ("int", 1, None, False, False),
    "pn_smooth_bins": ("int", 0, None, False, False),
    "pn_clutter_line_hz": ("float", 0, None, True, False),
    "pn_line_guard_frac": ("float", 0, 0.5, False, False),
    "pn_body_guard_hz": ("float", 0, None, False, False),
    "body_smooth_cpis": ("int", 0, None, False, False),
    "margin_asymmetry_db": ("float", 0, None, False, False),
    "margin_std_db": ("float", 0, None, False, False),
    "margin_body_std_db": ("float", 0, None, False, False),
    "margin_lag_s": ("float", 0, None, False, False),
    "margin_scale": ("float", 0, None, False, False),
    "margin_floor_rise_db": ("float", 0, None, False, False),
    "min_blade_wavelengths": ("float", 0, None, False, False),
    "min_log_coverage": ("float", 0, 1, True, False),
    "figures": ("bool", None, None, False, False),
}


def _check_config(values: dict, source) -> dict:
    """Every field of ``values`` checked and normalised (ints, floats, tuples), then
    the constraints between fields; raises :class:`ConfigError`."""
    out = {k: _check_value(source, k, v, *_RULES[k]) for k, v in values.items()}

    def need(cond, key, problem, expected):
        if not cond:
            raise ConfigError(source, f"diagnosis.{key}", problem, expected)

    need(out["scale_max"] > out["scale_min"], "scale_max", f"is {out['scale_max']:g}",
         f"> diagnosis.scale_min ({out['scale_min']:g})")
    need(out["scale_step"] < out["scale_max"] - out["scale_min"], "scale_step", f"is {out['scale_step']:g}",
         f"< scale_max - scale_min ({out['scale_max'] - out['scale_min']:g})")
    need(out["lag_step_s"] <= out["max_lag_s"], "lag_step_s", f"is {out['lag_step_s']:g}",
         f"<= diagnosis.max_lag_s ({out['max_lag_s']:g})")
    need(out["pn_outer_hz"] > out["pn_inner_hz"], "pn_outer_hz", f"is {out['pn_outer_hz']:g}",
         f"> diagnosis.pn_inner_hz ({out['pn_inner_hz']:g})")
    return out


@dataclass(frozen=True)
class DiagnosisConfig:
    """Settings of the diagnosis (``diagnosis:`` section of the config).

    Parameters
    ----------
    n_fft : int
        CPI length [pulses] of the STFT the statistics are read from.
    alpha : float
        Family-wise false-alarm level of the held-out tests: Bonferroni over the
        causes, at alpha / (k (k + 1)) for greedy step k (:func:`step_threshold`).
    block_cpis : int
        CPIs per block of the two alternating held-out folds.
    margin_* : float
        Relevance margins: a significant cause is named only if its fitted effect is
        at least this (about half the catalog's detectable size).
    model_floor_db : float
        Std [dB] of per-CPI power the paper's model is allowed to miss (beyond noise).
    min_blade_wavelengths : float
        Blades shorter than this many wavelengths (below the thin wire's half-wave
        resonance) have rotor lines below the noise: such drones (the Mini 2's
        0.06 m blades are 0.27 wavelengths at L-band) are not diagnosed.
    min_log_coverage : float
        Fraction of the flight's time span the motor log must cover; CPIs outside the
        log's span are not used.

    Invalid values raise :class:`~microdoppler.errors.ConfigError` naming
    ``diagnosis.<field>`` (:meth:`from_dict` names the config file).
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
    margin_std_db: float = 2.0
    margin_body_std_db: float = 2.0
    margin_lag_s: float = 0.15
    margin_scale: float = 0.025
    margin_floor_rise_db: float = 3.0
    min_blade_wavelengths: float = 0.5
    min_log_coverage: float = 0.5
    figures: bool = True

    @classmethod
    def from_dict(cls, d: dict | None, source="config") -> "DiagnosisConfig":
        """The config of the mapping ``d`` (field -> value); ``source`` (the config
        file) is named in errors: ``<source>: diagnosis.<field>: <problem> (expected ...)``."""
        if d is None:
            d = {}
        if not isinstance(d, dict):
            raise ConfigError(source, "diagnosis", f"is a {type(d).__name__}", "a mapping of diagnosis settings")
        names = [f.name for f in fields(cls)]
        for k in d:
            if k not in names:
                raise ConfigError(source, f"diagnosis.{k}", "unknown key", f"one of {', '.join(names)}")
        values = {f.name: f.default for f in fields(cls)}
        values.update(d)
        return cls(**_check_config(values, source))

    def __post_init__(self):
        _check_config({f.name: getattr(self, f.name) for f in fields(self)}, "DiagnosisConfig")


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


#: the report format written by :func:`diagnose` (``shared/formats/flight-zarr.md``)
REPORT_SCHEMA = "diagnosis-report/2"
#: causes whose tests need the rotors' HERM lines
ROTOR_CAUSES = ("sideband_asymmetry", "sideband_fading", "motor_log_lag", "motor_speed_scale")


class Undiagnosable(InputError):
    """A flight the diagnosis cannot judge (a bird, a Mini, no usable motor log, too
    short, no visible rotor lines). :func:`diagnose_flight` raises it (an
    :class:`InputError` naming the field); :func:`diagnose` lists the flight as
    ``skipped`` with ``reason``."""

    def __init__(self, source, field: str, problem: str, expected: str | None = None, *, reason: str | None = None):
        super().__init__(source, field, problem, expected)
        self.reason = reason or (f"{field}: {problem}" + (f" (expected {expected})" if expected else ""))


def flight_log(flight, motor_log: MotorLog | None) -> MotorLog | None:
    if motor_log is not None:
        return motor_log
    if flight.has_motor_log:
        return MotorLog(flight.motors_time_s, flight.motors_rpm, str(flight.flight_id))
    return None


def _n_cpis(n_pulses: int, n_fft: int) -> int:
    hop = int(round(n_fft * 0.5))  # features.stft_power's 50 % overlap
    return 0 if n_pulses < n_fft else 1 + (n_pulses - n_fft) // hop


def check_diagnosable(flight, motor_log: MotorLog | None, cfg: DiagnosisConfig) -> MotorLog:
    """The flight's motor log, checked; :class:`Undiagnosable` when the flight cannot
    be diagnosed: not a drone, blades too short for visible rotor lines (Minis), no
    motor log, a log that :func:`~microdoppler.io.motorlog.check_motor_log` rejects
    (all zeros, a median speed implausible for a rotor, e.g. rev/s declared as rpm),
    a log covering less than ``min_log_coverage`` of the flight's span, or fewer CPIs
    than two held-out folds need."""
    fid = flight.flight_id
    a = flight.attrs
    target = a.get("target")
    if target != "drone":
        reason = {"bird": "bird flight: no rotors", "none": "target-free recording: no rotors"}.get(
            target, f"target {target!r}: not a drone")
        raise Undiagnosable(fid, "attrs.target", f"is {target!r}", "'drone' (only drones are diagnosed)", reason=reason)
    lam = flight.wavelength_m
    blade = float(a["blade_length_m"])
    if blade < cfg.min_blade_wavelengths * lam:
        size = f"{blade:g} m = {blade / lam:.2f} wavelengths at {flight.carrier_hz / 1e9:.3g} GHz"
        raise Undiagnosable(
            fid, "attrs.blade_length_m", f"is {size}: the rotor lines are below the noise",
            f">= {cfg.min_blade_wavelengths:g} wavelengths (diagnosis.min_blade_wavelengths)",
            reason=f"{a.get('drone_model', 'drone')}: rotor lines invisible (attrs.blade_length_m {size}, "
                   f"< {cfg.min_blade_wavelengths:g})")
    log = flight_log(flight, motor_log)
    if log is None:
        raise Undiagnosable(fid, "motors", "no motor log", "motors/time_s + motors/rpm or a motor log",
                            reason="no motor log")
    t_field, s_field = "motors/time_s", "motors/rpm"
    src = fid if motor_log is None else (log.source or fid)
    try:
        log = check_motor_log(src, log.time_s, log.rpm, unit="rpm", time_field=t_field, speed_field=s_field)
    except InputError as e:
        raise Undiagnosable(e.source, e.field, e.problem, e.expected,
                            reason=f"unusable motor log: {e.field}: {e.problem}"
                                   + (f" (expected {e.expected})" if e.expected else "")) from None
    span = flight.duration_s
    t0, t1 = float(log.time_s[0]), float(log.time_s[-1])
    cover = max(0.0, min(t1, span) - max(t0, 0.0)) / span
    if cover < cfg.min_log_coverage:
        problem = f"spans {t0:.4g} to {t1:.4g} s, {cover:.0%} of the flight's 0 to {span:.4g} s"
        expected = f">= {cfg.min_log_coverage:.0%} of the flight covered (diagnosis.min_log_coverage)"
        raise Undiagnosable(src, t_field, problem, expected,
                            reason=f"motor log outside the flight: {t_field}: {problem} (expected {expected})")
    n_t = _n_cpis(len(flight.iq), cfg.n_fft)
    need = 2 * cfg.block_cpis + 4
    if n_t < need:
        n_need = cfg.n_fft + (need - 1) * int(round(cfg.n_fft * 0.5))
        problem = f"has {len(flight.iq)} pulses = {n_t} CPIs of {cfg.n_fft}"
        expected = f">= {need} CPIs = {n_need} pulses (two held-out folds of diagnosis.block_cpis={cfg.block_cpis})"
        raise Undiagnosable(fid, "iq", problem, expected,
                            reason=f"flight too short: iq: {problem} (expected {expected})")
    return log


def _check_measured(fid, M, tests: dict, cfg: DiagnosisConfig) -> None:
    """:class:`Undiagnosable` when the measurement leaves nothing to test: too few
    usable CPIs, or no test of the rotors' lines possible (none visible)."""
    nv = int(M.valid.sum())
    if nv < 2 * cfg.block_cpis or not any(t.testable for t in tests.values()):
        problem = (f"has {nv} of {len(M.t_s)} CPIs usable (body Doppler outside the clutter notch, "
                   f"no floor artifact, within the motor log's span)")
        expected = f">= {2 * cfg.block_cpis} usable CPIs"
        raise Undiagnosable(fid, "iq", problem, expected,
                            reason=f"too few usable CPIs: iq: {problem} (expected {expected})")
    if not any(tests[c].testable for c in ROTOR_CAUSES):
        problem = ("shows no rotor lines: no HERM sideband pair above the noise and too few CPIs whose line "
                   "pattern matches the motor log's")
        raise Undiagnosable(fid, "iq", problem, "visible HERM lines of the rotors",
                            reason=f"no visible rotor sidebands: iq: {problem}")


def run_tests(flight, motor_log: MotorLog, cfg: DiagnosisConfig):
    """Measurements, calibration and every cause's :class:`~.causes.CauseTest`
    against the paper's model (no cause named yet)."""
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


#: pairs of causes whose statistics depend on each other: the test of one is redone
#: with the other's extension in both models once the other is named. Every other
#: cause's statistic is unchanged by another cause's extension in both models (the
#: held-out likelihood ratio is the same number): the asymmetry statistic is a
#: ratio of upper to lower sidebands (a common blade gain, i.e. fading, cancels); the
#: fading statistic is the common-mode sideband power relative to each harmonic's
#: median (a constant per-side gain, i.e. asymmetry, cancels, and so do lag and
#: scale, since the sidebands are read where the measured lines are and the
#: envelope's speed tilt is taken out at the measured speed); the body
#: statistic reads the body line only; the phase-noise likelihood keeps the body's
#: own skirt (a fluctuating body) and the wind-blown clutter in both models.
COUPLED = {"motor_log_lag": {"motor_speed_scale"}, "motor_speed_scale": {"motor_log_lag"}}


def conditional_tests(M, calib, cfg: DiagnosisConfig, tests: dict, given) -> dict:
    """The tests with the extensions of the causes in ``given`` in both models of
    every other cause (only :data:`COUPLED` pairs need recomputing)."""
    given = frozenset(given)
    if not given & set(COUPLED):
        return tests
    fold = C.folds(len(M.t_s), cfg.block_cpis)
    out = dict(tests)
    for cause, partners in COUPLED.items():
        g = given & partners
        if not g or not tests[cause].testable:
            continue
        lag, sc = C.test_log(M, cfg, fold, frozenset(g))
        out[cause] = lag if cause == "motor_log_lag" else sc
    return out


def _significant(t, thr: float) -> bool:
    # the e-value bound holds only for likelihood ratios scored on held-out data
    return bool(t.testable and t.held_out and t.log_e >= thr)


def step_threshold(n_testable: int, step: int, alpha: float) -> float:
    """log e-value threshold of greedy step ``step`` (1-based): Bonferroni over the
    ``n_testable`` causes at level alpha_k = alpha / (k (k + 1)), so that the levels
    of all steps add up to alpha (sum 1 / (k (k + 1)) = 1). Each step's e-values are
    held-out likelihood ratios against the model with the causes already named, so
    a step at which every true cause is already named names a spurious one with
    probability <= alpha_k, and a flight's false names over all such steps with
    probability <= alpha. (A step taken while a true cause is still missing tests
    against a wrong baseline; the conditioning on the named causes and the
    relevance margins guard that case, which the bound does not cover.)"""
    k = max(int(step), 1)
    return float(np.log(max(n_testable, 1) * k * (k + 1) / alpha))


def _strength(t) -> float:
    """Held-out log-likelihood gain per observation (the statistics differ in size:
    per-CPI values vs. periodogram ordinates)."""
    return t.log_e / max(t.n_obs, 1)


def decide(tests: dict, cfg: DiagnosisConfig, step: int = 1, n_testable: int | None = None) -> tuple[str, float]:
    """The strongest significant and relevant cause of one greedy step (``"none"``
    when there is none) and that step's log e-value threshold (Bonferroni over
    ``n_testable`` causes, default the testable ones in ``tests``)."""
    n = sum(t.testable for t in tests.values()) if n_testable is None else n_testable
    thr = step_threshold(n, step, cfg.alpha)
    cands = [t for t in tests.values() if _significant(t, thr) and t.relevant]
    if not cands:
        return "none", thr
    return max(cands, key=_strength).cause, thr


def decide_all(M, calib, cfg: DiagnosisConfig, tests: dict, fix=None) -> tuple[list, list]:
    """Greedy selection of every significant and relevant cause.

    Step k tests each cause not yet named against the paper's model plus the named
    causes' extensions (both models, :func:`conditional_tests`), at the threshold
    :func:`step_threshold` (k); the strongest passing cause is named, until none
    passes. Returns (named causes in the order named, the steps' records)."""
    fix = fix or (lambda t: t)
    named, steps = [], []
    while True:
        cur = fix(conditional_tests(M, calib, cfg, tests, named))
        rest = {c: t for c, t in cur.items() if c not in named}
        n = sum(t.testable for t in cur.values())
        cause, thr = decide(rest, cfg, step=len(named) + 1, n_testable=n)
        steps.append({"given": list(named), "log_evalue_threshold": thr,
                      "log_evalue": {c: t.log_e for c, t in rest.items() if t.testable}, "named": cause})
        if cause == "none":
            break
        named.append(cause)
    return named, steps


def gain(t) -> dict:
    """The ``gain`` of a report entry: the held-out negative log-likelihood per
    observation of the cause's statistic without (baseline) and with (extended) its
    extension; ``held_out`` is the test's own record of whether each fold was scored
    with parameters fitted on the other fold only."""
    return {"metric": f"nll_per_obs:{t.statistic}", "baseline": t.nll_base, "extended": t.nll_ext,
            "held_out": bool(t.held_out)}


def cause_entry(t, thr: float, given=(), step: int = 1) -> dict:
    """One entry of a flight's ``causes`` list (report 2): ``t`` is the cause's test
    with the other named causes (``given``) in both models; ``thr`` the threshold of
    the greedy step (``step``) that named it."""
    return {"cause": t.cause,
            "extension": {"name": t.cause, "params": {k: float(v) for k, v in t.params.items()}},
            "gain": gain(t),
            "evidence": {"log_evalue": t.log_e, "log_evalue_threshold": thr, "n_heldout_obs": t.n_obs,
                         "effect": t.effect, "named_at_step": int(step), "other_causes_in_both_models": list(given),
                         **t.evidence}}


def skipped_entry(flight_id: str, reason: str) -> dict:
    return {"flight_id": flight_id, "cause": "skipped", "causes": [], "reason": reason}


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
    flight : microdoppler.io.flightzarr.Flight
        A measured drone flight (``target == "drone"``).
    motor_log : MotorLog, optional
        Its motor log; default the store's ``motors/*`` arrays.
    config : DiagnosisConfig or dict, optional
    figure_path : path, optional
        Where to write the figure (measured vs baseline vs extended, residual).

    Returns
    -------
    dict
        The report entry (``diagnosis-report/2``): flight_id, cause (the first of
        ``causes`` or ``"none"``), causes (every significant and relevant cause,
        strongest first, each with its extension, held-out gain with the other named
        causes in both models, and evidence; see :func:`decide_all`) and the
        flight's evidence (every test against the paper's model, the greedy steps,
        the calibration).

    Raises
    ------
    Undiagnosable
        (an :class:`InputError` naming the field) when the flight cannot be
        diagnosed: see :func:`check_diagnosable`; also when no rotor line is visible.
    """
    cfg = config if isinstance(config, DiagnosisConfig) else DiagnosisConfig.from_dict(config)
    t0 = time.perf_counter()
    fid = flight.flight_id
    log = check_diagnosable(flight, motor_log, cfg)
    M, calib, tests = run_tests(flight, log, cfg)
    from ..io.inventory import RADAR_SOURCE

    radar_log = (flight.attrs.get("motors_source") == "radar" if motor_log is None
                 else str(motor_log.source).startswith(RADAR_SOURCE))

    def fix(ts: dict) -> dict:
        if radar_log:
            # the log was estimated from this recording's own HERM lines: it cannot be
            # late or scaled against them
            for name in ("motor_log_lag", "motor_speed_scale"):
                ts[name].testable = False
                ts[name].evidence = {"reason": "motors_source is radar: the motor log was estimated from this "
                                               "recording's HERM lines, so lag and scale are not testable"}
        return ts

    tests = fix(tests)
    _check_measured(fid, M, tests, cfg)
    named, steps = decide_all(M, calib, cfg, tests, fix)
    thr = steps[0]["log_evalue_threshold"]
    thr_of = {c: steps[i]["log_evalue_threshold"] for i, c in enumerate(named)}
    # each named cause re-tested with all the other named causes' extensions in both
    # models (backward check): a cause named early that a later one explains (a lag
    # fitted to what is a scale error) is dropped, the weakest first, until every
    # named cause holds with the others in both models; these tests give the gains
    dropped = []
    while True:
        final = {c: fix(conditional_tests(M, calib, cfg, tests, set(named) - {c}))[c] for c in named}
        failing = [c for c in named if not (_significant(final[c], thr_of[c]) and final[c].relevant)]
        if not failing:
            break
        worst = min(failing, key=lambda c: _strength(final[c]))
        dropped.append({"cause": worst, "given": sorted(set(named) - {worst}), "log_evalue": final[worst].log_e,
                        "log_evalue_threshold": thr_of[worst], "relevant": bool(final[worst].relevant)})
        named.remove(worst)
    order = sorted(named, key=lambda c: -(final[c].nll_base - final[c].nll_ext))
    causes = [cause_entry(final[c], thr_of[c], given=sorted(set(named) - {c}),
                          step=next(i for i, st in enumerate(steps, 1) if st["named"] == c)) for c in order]
    evidence = {
        "log_evalue_threshold": thr,
        "multiple_testing": "greedy steps k = 1, 2, ...: Bonferroni over the testable causes at level "
                            "alpha / (k (k + 1)) per step (levels add up to alpha)",
        "steps": steps,
        "dropped_with_the_others_in_both_models": dropped,
        "calibration": {"s_body": calib["s_body"], "s_blade": calib["s_blade"], "alpha_s": calib["alpha_s"]},
        "per_harmonic_power_error_db": calib["per_harmonic_power_error_db"],
        "tests": {c: {"log_evalue": t.log_e, "n_heldout_obs": t.n_obs, "significant": _significant(t, thr),
                      "relevant": bool(t.relevant), "testable": bool(t.testable), "params": t.params,
                      "statistic": t.statistic, "heldout_nll_base": t.nll_base, "heldout_nll_ext": t.nll_ext,
                      "held_out": bool(t.held_out), **t.evidence}
                  for c, t in tests.items()},
        "n_cpis": int(len(M.t_s)), "n_valid_cpis": int(M.valid.sum()),
        "motor_log_speed_hz": float(np.median(M.f_log_hz)),
        "seconds": time.perf_counter() - t0,
    }
    cause = causes[0]["cause"] if causes else "none"
    entry = _r({"flight_id": fid, "cause": cause, "causes": causes, "evidence": evidence})
    if figure_path is not None and cfg.figures:
        from .figure import plot_diagnosis

        plot_diagnosis(flight, log, M, calib, {**tests, **final}, cause, figure_path, cfg)
    return entry


def write_json(obj, path) -> Path:
    """Write ``obj`` as JSON, atomically (:func:`microdoppler.io.outputs.atomic_file`)."""
    with atomic_file(path) as tmp:
        tmp.write_text(json.dumps(obj, indent=1))
    return Path(path)


def diagnose(paths, out_json, *, motor_logs: dict | None = None, config=None, figures_dir=None,
             log=print) -> dict:
    """Diagnose the flights at ``paths`` and write the report JSON (``diagnosis-report/2``).

    Every flight appears in the report: flights that cannot be diagnosed (birds,
    target-free recordings, Minis, drones without a usable motor log, too short, no
    visible rotor lines) with cause ``skipped`` and the ``reason``. A store that
    breaks the format is an error (:class:`InputError`). ``motor_logs`` maps
    flight_id -> MotorLog (overrides the stores' own logs).
    """
    cfg = config if isinstance(config, DiagnosisConfig) else DiagnosisConfig.from_dict(config)
    entries = []
    for p in paths:
        f = read_flight(p)
        ml = (motor_logs or {}).get(f.flight_id)
        fig = Path(figures_dir) / f"{f.flight_id}.png" if figures_dir else None
        try:
            e = diagnose_flight(f, motor_log=ml, config=cfg, figure_path=fig)
        except Undiagnosable as exc:
            e = skipped_entry(f.flight_id, exc.reason)
            log(f"{f.flight_id}: skipped: {exc.reason}")
        else:
            named = "; ".join(f"{c['cause']} {c['extension']['params']}" for c in e["causes"]) or "none"
            log(f"{f.flight_id}: {named} ({e['evidence']['seconds']:.1f} s)")
        entries.append(e)
    report = {"schema": REPORT_SCHEMA, "catalog": list(CATALOG), "flights": entries}
    write_json(report, out_json)
    return report
