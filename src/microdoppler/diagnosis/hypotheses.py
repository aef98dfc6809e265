"""Step 2 of the diagnosis: one held-out likelihood test per catalog cause.

Each cause's test is its module's (:mod:`microdoppler.causes`, ``CauseSpec.test``);
:func:`run_tests` runs every registered cause's, the couplings below come from the
cause modules' declarations (``test_partners``, ``reads_sidebands``,
``floor_partner``), and the shared machinery is :mod:`microdoppler.causes.heldout`.
The names below are re-exported from there for the figure, the benchmarks and the tests.

:func:`run_tests` reads the flight's :class:`~.measure.Measurements` only (never the
I/Q or a spectrogram) and returns every cause's :class:`CauseTest` against the
paper's model, and the tests of the causes whose statistics depend on each other
(:data:`COUPLED`) with the other one in both models, for :mod:`.decide`.

Every cause is tested the same way. The CPIs are cut into alternating blocks of
``block_cpis`` (folds A and B). On each fold the paper's model (baseline) and the
model extended by the cause are fitted, and both are scored on the *other* fold by
the log-likelihood of the cause's statistic. The two held-out likelihood ratios are
averaged: under the baseline the average has expectation <= 1 whatever was fitted
(each ratio is a likelihood ratio on data its fit did not see), so it is an e-value
and P(ratio >= 1/a) <= a (Markov). A cause is *significant* when its log e-value
exceeds the threshold of its greedy step (``decide.step_threshold``: Bonferroni over the
causes at level alpha / (k (k + 1)) at step k) and *relevant* when its fitted effect
is at least a margin (a fraction of the catalog's detectable size). ``decide.decide_all``
names causes greedily, strongest first, each later step testing the remaining causes
with the named causes' extensions in both models (``given`` of :func:`test_log`; the
other statistics are unchanged by another cause's extension, see :data:`COUPLED`).

Sizes and correlation times of the fluctuating causes are estimated jointly and
analytically (:func:`fit_gain_process`, :func:`fit_gain_process_ml`: variogram and
exact likelihood of the per-window dB series, window averaging and noise accounted
for), without simulating any process: the body's on
short windows (:func:`.measure.body_power_fine`), the fading's on short windows too
(:func:`fading_estimate_fine`: the harmonics' cluster powers on windows of n_fft / 2
pulses, the rotors' beats taken out as a nuisance measured where the fading
cancels, exact likelihood), on the CPIs where too few short windows are usable
(:func:`fading_estimate`), both after taking out the tilt of the harmonics by the
rotor-speed changes. The fading is named by the CPI grid's size (as before the
short windows).

A test's ``held_out`` records whether its ``nll_base``/``nll_ext`` really are held-out
scores: both folds held observations, each was scored with parameters fitted on the
other alone, the scores are finite, and no fit borrowed data outside its fold (the
fading test's within-CPI scatter falls back to the whole flight when a fold has too
few multi-harmonic CPIs). Only held-out tests can be significant. The shared
preprocessing (linear trend in time and log range, the body's moving average, the
rotor-speed tilt of the harmonics, fitted where a common gain cancels) is computed
once on the whole flight and is the same for both models.

Statistics (per CPI) and models:

- ``sideband_asymmetry``: d = 10 log10(upper / lower sideband power) over the usable
  harmonic pairs; baseline N(0, s^2), extension N(a, s^2).
- ``sideband_fading``: mean over the harmonics (pairs counted by their summed power)
  of each pair's power relative to its median [dB], with the paper's envelope's
  tilt by the rotor speed taken out (:func:`speed_tilt`), detrended for time and
  range; baseline N(0, within-CPI scatter / K + m^2), extension adds a fitted variance.
- ``body_fluctuation``: body power [dB], detrended, same models.
- ``motor_log_lag`` / ``motor_speed_scale``: y = ln(measured HERM spacing / the one the
  log predicts at that CPI); baseline N(0, s^2), lag N(ln f(t+lag)/f(t), s^2), scale
  N(ln scale, s^2), each contaminated by 5 % outliers (a wide normal, the same in both
  models); with the other one named, it is in both models (:func:`test_log`).
- ``phase_noise``: Whittle likelihood of the periodogram ordinates near the clutter
  line (off the target's lines): baseline PSD = the background recording's, extension
  adds a skirt (line power) / 200 Hz x (q_flat + q_slope (50 Hz / f)^2) around the
  clutter line and the body (a flat, Gaussian-shaped or 1/f-like phase-noise spectrum
  is a mix of the two over 35-95 Hz); ``skirt_dbc_hz`` = 10 log10((q_flat + q_slope) /
  200 Hz) is its density at 50 Hz, ``rms_rad`` = sqrt(ln(1 + q_flat + q_slope)) the
  rms of the flat process with that skirt.

The fixed settings read here are :mod:`microdoppler.causes.config`'s constants.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from ..causes import registry
from ..causes.blade_imbalance import (
    imbalance_from_ratio,
    imbalance_observations,  # noqa: F401 (re-exported)
    non_multiple_observations,
    test_imbalance,
)
from ..causes.body_fluctuation import body_estimate, test_body  # noqa: F401 (re-exported)
from ..causes.heldout import (
    B,
    LOG2PI,
    SHAPES,
    TAU_GRID_S,
    CauseTest,
    _crossfit,  # noqa: F401 (re-exported)
    _detrend,
    _gauss_ll,
    _lag_grid,
    _ml_extra_var,
    _moving_average,
    _power_fluct_test,
    fit_gain_process,
    fit_gain_process_ml,
    fit_variogram,
    folds,
    harmonic_speed_slope,
    model_cov_db2,
    variogram,
    window_offsets,
)
from ..causes.motor_log import test_log  # noqa: F401 (re-exported)
from ..causes.phase_noise import profile_skirt_test, test_phase_noise  # noqa: F401 (re-exported)
from ..causes.sideband_asymmetry import test_asymmetry  # noqa: F401 (re-exported)
from ..causes.sideband_fading import (
    common_gain_correlation,
    envelope_tilt,
    fading_estimate,
    fading_estimate_fine,
    measured_speed,
    speed_tilt,
    test_fading,
)
from .config import DiagnosisConfig
from .measure import Measurements, Undiagnosable


def cause_order() -> tuple:
    """The registered causes, in the order they are tested."""
    return registry.names()


def body_causes() -> tuple:
    """Causes whose tests need the body line (not testable when it lies in the clutter notch)."""
    return tuple(s.name for s in registry.specs() if s.line == "body")


def rotor_causes() -> tuple:
    """Causes whose tests need the rotors' HERM lines."""
    return tuple(s.name for s in registry.specs() if s.line == "rotor")


def log_coupled() -> dict:
    """cause -> the causes whose extensions enter its own test once named (``test_partners``)."""
    return {s.name: set(s.test_partners) for s in registry.specs() if s.test_partners}


def floor_partners() -> frozenset:
    """Causes that, named, lift the floor under the sidebands (``floor_partner``)."""
    return frozenset(s.name for s in registry.specs() if s.floor_partner)


def skirt_coupled() -> dict:
    """cause -> floor partners, for the causes whose tests read the sidebands."""
    fp = floor_partners()
    return {s.name: set(fp) for s in registry.specs() if s.reads_sidebands}


def coupled() -> dict:
    """Pairs of causes whose statistics depend on each other (:data:`COUPLED`), from the registry."""
    return {**log_coupled(), **skirt_coupled()}


#: the built-in causes' order and couplings (the functions above follow the registry)
CAUSE_ORDER = cause_order()
#: causes whose tests need the body line (not testable when it lies in the clutter notch)
BODY_CAUSES = body_causes()
#: causes whose tests need the rotors' HERM lines
ROTOR_CAUSES = rotor_causes()
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
#: The sideband tests depend on the floor partners the other way: a phase noise's
#: skirt raises the floor under the sidebands near the clutter line, where the
#: raised-floor guard drops them; with it named, they are read with its fitted skirt
#: in the floor's model (:func:`.measure.given_skirt`, both models), so the sideband
#: causes are judged on what the skirt leaves. Likewise a named blade imbalance: its
#: rotation-rate lines lie between the blade-passing lines and lift the sidebands'
#: local floor (:func:`.measure.given_imbalance`). A floor partner's own test does not
#: change with a sideband cause.
LOG_COUPLED = log_coupled()
FLOOR_PARTNERS = floor_partners()
SKIRT_COUPLED = skirt_coupled()
COUPLED = coupled()


@dataclass(frozen=True)
class TestResults:
    """Every cause's test of one flight (:func:`run_tests`).

    ``tests``: cause -> :class:`CauseTest` against the paper's model (no cause named);
    ``conditional``: (cause, partners) -> the cause's test with the extensions of
    ``partners`` (a non-empty frozenset of its :data:`COUPLED` partners) in both
    models, for every testable coupled cause (:func:`.decide.tests_given` assembles
    the tests with any set of named causes in both models from the two)."""

    __test__ = False  # not a pytest class

    tests: dict
    conditional: dict


def check_testable(M: Measurements, tests: dict, cfg: DiagnosisConfig) -> None:
    """:class:`~.measure.Undiagnosable` when the measurement leaves nothing to test:
    too few usable CPIs, no cause testable (each test's reason named), or no test of the
    rotors' lines possible (none visible)."""
    fid = M.flight_id
    nv = int(M.valid.sum())
    if nv < 2 * cfg.block_cpis:
        problem = (
            f"has {nv} of {len(M.t_s)} CPIs usable (body Doppler outside the clutter notch, "
            f"no floor artifact, within the motor log's span)"
        )
        expected = f">= {2 * cfg.block_cpis} usable CPIs"
        raise Undiagnosable(
            fid, "iq", problem, expected, reason=f"too few usable CPIs: iq: {problem} (expected {expected})"
        )
    if not any(t.testable for t in tests.values()):
        # enough CPIs, but every test declined: say why each did, not that CPIs lack
        why = "; ".join(f"{c}: {t.evidence.get('reason', 'not testable')}" for c, t in tests.items())
        problem = f"has {nv} usable CPIs but no cause is testable ({why})"
        raise Undiagnosable(
            fid, "iq", problem, "a cause the flight's data can test", reason=f"no cause testable: iq: {problem}"
        )
    if not any(tests[c].testable for c in rotor_causes()):
        problem = (
            "shows no rotor lines: no HERM sideband pair above the noise and too few CPIs whose line "
            "pattern matches the motor log's"
        )
        raise Undiagnosable(
            fid, "iq", problem, "visible HERM lines of the rotors", reason=f"no visible rotor sidebands: iq: {problem}"
        )


def run_tests(M: Measurements, cfg: DiagnosisConfig) -> TestResults:
    """Every registered cause's :class:`CauseTest` of the measured flight ``M``:
    against the paper's model, and for the :data:`COUPLED` causes also with their
    partners in both models (:class:`TestResults`).

    A cause whose test needs the body line is not testable with the body in the
    clutter notch; a cause may declare a flight untestable itself
    (``CauseSpec.untestable``: a motor log estimated from the recording's own HERM
    lines cannot be late or scaled against them).

    Raises
    ------
    Undiagnosable
        When nothing is left to test (:func:`check_testable`).
    """
    fold = folds(len(M.t_s), cfg.block_cpis)
    specs = registry.specs()
    tests = {s.name: s.test(M, cfg, fold) for s in specs}
    if M.info.get("body_in_notch"):
        for s in specs:
            if s.line == "body":
                tests[s.name] = CauseTest(
                    s.name,
                    testable=False,
                    evidence={
                        "reason": "body Doppler inside the clutter notch (hovering, on a stand or a staring "
                        "recording): the body line is not measurable"
                    },
                )
    for s in specs:
        reason = s.untestable(M)
        if reason is not None:
            tests[s.name].testable = False
            tests[s.name].evidence = {"reason": reason}
    check_testable(M, tests, cfg)
    conditional = {}
    for s in specs:
        if not s.test_partners or not tests[s.name].testable:
            continue
        partners = s.test_partners
        for r in range(1, len(partners) + 1):
            for g in combinations(sorted(partners), r):
                conditional[(s.name, frozenset(g))] = s.test(M, cfg, fold, frozenset(g))
    conditional.update(tests_given_skirt(M, cfg, fold, tests))
    return TestResults(tests, conditional)


def tests_given_skirt(M: Measurements, cfg: DiagnosisConfig, fold, tests: dict) -> dict:
    """The sideband tests (``reads_sidebands``, :data:`SKIRT_COUPLED`) with what lifts
    the floor under the sidebands in its model, keyed ``(cause, partners)`` as
    :attr:`TestResults.conditional`, for every non-empty set of the available floor
    partners (``CauseSpec.floor_available``: the phase-noise skirt when phase noise
    is testable and its skirt not nil, :func:`.measure.given_skirt`; a blade
    imbalance's rotation lines when its test is testable and favours it on held-out
    data, :func:`.measure.given_imbalance`). The partners enter the floor's model in
    the order of their ``floor_stage``. Empty when none is available. A test whose
    pairs the partners do not change is the same object."""
    specs = registry.specs()
    available = [s for s in specs if s.floor_partner and s.floor_available(tests.get(s.name))]
    readers = [s for s in specs if s.reads_sidebands]
    out = {}
    cache = {}

    def floor_model(g, clear_side):
        Ms, key = M, ()
        for p in sorted(g, key=lambda s: s.floor_stage):
            key = key + ((p.name, clear_side if p.floor_side_aware else None),)
            if key not in cache:
                cache[key] = p.floor_model(Ms, tests[p.name], clear_side=clear_side)
            Ms = cache[key]
        return Ms

    for r in range(1, len(available) + 1):
        for g in combinations(available, r):
            names = frozenset(p.name for p in g)
            for s in readers:
                Ms = floor_model(g, s.clear_side)
                changed = not (
                    np.array_equal(Ms.pair_ok, M.pair_ok)
                    and np.array_equal(Ms.up, M.up)
                    and np.array_equal(Ms.lo, M.lo)
                )
                t = s.test(Ms, cfg, fold) if changed else tests[s.name]
                if changed and t.testable:
                    n_new = int((Ms.pair_ok & ~M.pair_ok & M.valid[:, None]).sum())
                    for p in g:
                        t.evidence = {**t.evidence, **p.floor_evidence(n_new)}
                out[(s.name, names)] = t
    return out
