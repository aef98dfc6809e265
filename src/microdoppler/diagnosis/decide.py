"""Step 3 of the diagnosis: name the causes and write the flight's report entry.

:func:`decide_flight` reads the tests (:class:`~.hypotheses.TestResults`) and names
every significant and relevant cause greedily (:func:`decide_all`: each later cause
tested with the named causes' extensions in both models, at a step-wise Bonferroni
threshold, :func:`step_threshold`), re-tests each named cause with all the others in
both models (dropping one that no longer holds), measures each one's gain so, and
returns the report entry of ``shared/formats/flight-zarr.md``
(``diagnosis-report/2``) in a :class:`Decision`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .config import DiagnosisConfig
from .hypotheses import TestResults, coupled
from .measure import Measurements


def tests_given(T: TestResults, named) -> dict:
    """The tests with the extensions of the causes ``named`` in both models of every
    other cause: ``T.tests``, with each :data:`~.hypotheses.COUPLED` cause's test
    replaced by its test given the named partners (``T.conditional``); the other
    causes' statistics do not change."""
    named = frozenset(named)
    pairs = coupled()
    if not any(named & partners for partners in pairs.values()):
        return T.tests
    out = dict(T.tests)
    for cause, partners in pairs.items():
        key = (cause, frozenset(named & partners))
        # conditional tests exist where they were computed (a coupled cause testable
        # against the paper's model; a sideband cause given a non-nil skirt, which may
        # make it testable only then)
        if key[1] and key in T.conditional:
            out[cause] = T.conditional[key]
    return out


def _significant(t, thr: float) -> bool:
    # the e-value bound holds only for likelihood ratios scored on held-out data
    return bool(t.testable and t.held_out and t.log_e >= thr)


def _improves(t) -> bool:
    """The extension fits the held-out data better, pooled over both folds: the
    held-out negative log-likelihood per observation with the extension
    (``nll_ext``) below the paper's model's (``nll_base``). The log e-value averages
    the two folds' likelihood ratios, so one fold can carry it while the pooled fit
    gets worse; the report then says so (:func:`gain`)."""
    return bool(np.isfinite(t.nll_base) and np.isfinite(t.nll_ext) and t.nll_ext < t.nll_base)


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


def decide_all(T: TestResults, cfg: DiagnosisConfig) -> tuple[list, list]:
    """Greedy selection of every significant and relevant cause.

    Step k tests each cause not yet named against the paper's model plus the named
    causes' extensions (both models, :func:`tests_given`), at the
    threshold :func:`step_threshold` (k); the strongest passing cause is named, until
    none passes. Returns (named causes in the order named, the steps' records)."""
    named, steps = [], []
    while True:
        cur = tests_given(T, named)
        rest = {c: t for c, t in cur.items() if c not in named}
        n = sum(t.testable for t in cur.values())
        cause, thr = decide(rest, cfg, step=len(named) + 1, n_testable=n)
        steps.append(
            {
                "given": list(named),
                "log_evalue_threshold": thr,
                "log_evalue": {c: t.log_e for c, t in rest.items() if t.testable},
                "named": cause,
            }
        )
        if cause == "none":
            break
        named.append(cause)
    return named, steps


def gain(t) -> dict:
    """The ``gain`` of a report entry: the held-out negative log-likelihood per
    observation of the cause's statistic without (baseline) and with (extended) its
    extension; ``held_out`` is the test's own record of whether each fold was scored
    with parameters fitted on the other fold only; ``agrees_with_evalue`` whether the
    extension also improves the pooled fit (with ``why`` where it does not)."""
    out = {
        "metric": f"nll_per_obs:{t.statistic}",
        "baseline": t.nll_base,
        "extended": t.nll_ext,
        "held_out": bool(t.held_out),
        "agrees_with_evalue": _improves(t),
    }
    if not out["agrees_with_evalue"]:
        out["why"] = (
            "the log e-value averages the two folds' held-out likelihood ratios, so one fold can carry "
            "it; this gain pools both folds' log-likelihoods, and the extension fits the pooled "
            "held-out data worse: the evidence rests on part of the flight"
        )
    return out


def cause_entry(t, thr: float, given=(), step: int = 1) -> dict:
    """One entry of a flight's ``causes`` list (report 2): ``t`` is the cause's test
    with the other named causes (``given``) in both models; ``thr`` the threshold of
    the greedy step (``step``) that named it."""
    return {
        "cause": t.cause,
        "extension": {
            "name": t.cause,
            "params": {k: v if isinstance(v, dict) else float(v) for k, v in t.params.items()},
        },
        "gain": gain(t),
        "evidence": {
            "log_evalue": t.log_e,
            "log_evalue_threshold": thr,
            "n_heldout_obs": t.n_obs,
            "effect": t.effect,
            "named_at_step": int(step),
            "other_causes_in_both_models": list(given),
            **t.evidence,
        },
    }


def skipped_entry(flight_id: str, reason: str) -> dict:
    """The report entry of a flight that cannot be diagnosed."""
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


@dataclass(frozen=True)
class Decision:
    """What :func:`decide_flight` decided: the report ``entry``, the ``cause`` shown
    (the first named, or ``"none"``) and the tests the figure shows (``shown``: each
    cause's test against the paper's model, a named cause's with the other named
    causes in both models)."""

    entry: dict
    cause: str
    shown: dict


def decide_flight(M: Measurements, T: TestResults, cfg: DiagnosisConfig, *, started: float | None = None) -> Decision:
    """Name the flight's causes and write its report entry.

    A cause is named when its held-out log e-value passes the step's threshold and
    its fitted effect is relevant (beyond its margin). The e-value averages the two
    folds' likelihood ratios, the ``gain`` pools their log-likelihoods: where one fold
    carries the e-value while the pooled fit gets worse, the cause's entry says so
    (``gain.agrees_with_evalue`` false, with ``gain.why``).

    Parameters
    ----------
    M : Measurements
        The flight's measurement (:func:`.measure.measure`).
    T : TestResults
        Its tests (:func:`.hypotheses.run_tests`).
    cfg : DiagnosisConfig
    started : float, optional
        ``time.perf_counter()`` when the flight's diagnosis began: the entry's
        ``evidence.seconds`` counts from it (default: from this call).

    Returns
    -------
    Decision
        ``entry``: flight_id, cause (the first of ``causes`` or ``"none"``), causes
        (every significant and relevant cause, strongest first, each with its
        extension, held-out gain with the other named causes in both models, and
        evidence; see :func:`decide_all`) and the flight's evidence (every test
        against the paper's model, the greedy steps, the calibration).
    """
    t0 = time.perf_counter() if started is None else started
    tests = T.tests
    named, steps = decide_all(T, cfg)
    thr = steps[0]["log_evalue_threshold"]
    thr_of = {c: steps[i]["log_evalue_threshold"] for i, c in enumerate(named)}
    # each named cause re-tested with all the other named causes' extensions in both
    # models (backward check): a cause named early that a later one explains (a lag
    # fitted to what is a scale error) is dropped, the weakest first, until every
    # named cause holds with the others in both models; these tests give the gains
    dropped = []
    while True:
        final = {c: tests_given(T, set(named) - {c})[c] for c in named}
        failing = [c for c in named if not (_significant(final[c], thr_of[c]) and final[c].relevant)]
        if not failing:
            break
        worst = min(failing, key=lambda c: _strength(final[c]))
        dropped.append(
            {
                "cause": worst,
                "given": sorted(set(named) - {worst}),
                "log_evalue": final[worst].log_e,
                "log_evalue_threshold": thr_of[worst],
                "relevant": bool(final[worst].relevant),
                "improves_heldout_fit": _improves(final[worst]),
            }
        )
        named.remove(worst)
    order = sorted(named, key=lambda c: -(final[c].nll_base - final[c].nll_ext))
    causes = [
        cause_entry(
            final[c],
            thr_of[c],
            given=sorted(set(named) - {c}),
            step=next(i for i, st in enumerate(steps, 1) if st["named"] == c),
        )
        for c in order
    ]
    calib = M.calib
    evidence = {
        "log_evalue_threshold": thr,
        "multiple_testing": "greedy steps k = 1, 2, ...: Bonferroni over the testable causes at level "
        "alpha / (k (k + 1)) per step (levels add up to alpha)",
        "steps": steps,
        "dropped_with_the_others_in_both_models": dropped,
        "calibration": {"s_body": calib.s_body, "s_blade": calib.s_blade, "alpha_s": calib.alpha_s},
        "per_harmonic_power_error_db": calib.per_harmonic_power_error_db,
        "tests": {
            c: {
                "log_evalue": t.log_e,
                "n_heldout_obs": t.n_obs,
                "significant": _significant(t, thr),
                "relevant": bool(t.relevant),
                "improves_heldout_fit": _improves(t),
                "testable": bool(t.testable),
                "params": t.params,
                "statistic": t.statistic,
                "heldout_nll_base": t.nll_base,
                "heldout_nll_ext": t.nll_ext,
                "held_out": bool(t.held_out),
                **t.evidence,
            }
            for c, t in tests.items()
        },
        "n_cpis": int(len(M.t_s)),
        "n_valid_cpis": int(M.valid.sum()),
        "motor_log_speed_hz": float(np.median(M.f_log_hz)),
        "seconds": time.perf_counter() - t0,
    }
    cause = causes[0]["cause"] if causes else "none"
    entry = _r({"flight_id": M.flight_id, "cause": cause, "causes": causes, "evidence": evidence})
    return Decision(entry, cause, {**tests, **final})
