"""The diagnosis on flights made by an independent generator (issue 12, sections 2-3).

:mod:`independent_generator` shares no code with the emulator, the model extensions
or ``microdoppler.synthesis.processes``, and uses other radars, process shapes and constants
(telegraph fading, a smooth body process with correlation times 0.05-3 s, Gaussian
and 1/f-like phase noise, its own thin-wire blade sum and motor log). A fixed list of
seeded cases: one cause, two causes at once, and clean flights, on both of its
radars, at a measured body SNR >= 36 dB.

Tolerances (the issue's targets where it sets them):

- sizes (fading_std_db, body_std_db) within 20 %;
- asymmetry_db within 1 dB; lag_s within 0.1 s; scale - 1 within 20 %;
- skirt_dbc_hz within 1.5 dB (a density read off a 35-95 Hz fit of a flat plus a
  1/f^2 skirt: a Gaussian or 1/f-like spectrum is matched there to about 1 dB);
- timescale_s within a factor :data:`TIMESCALE_FACTOR` (2 for the body, 3 for the
  fading: one 40 s flight holds 15-25 fading correlation times, read on CPIs of
  0.46-0.63 s).

Known limits, kept as strict xfails so that they are seen (:data:`KNOWN_MISSES`).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import fast_loop
from independent_generator import GenCase, make_flight
from microdoppler.diagnosis import diagnose_flight
from microdoppler.spectra.snr import flight_body_snr_db

MIN_SNR_DB = 36.0
SIZE_REL = 0.2
#: timescale_s within this factor of the truth: body (0.05-3 s, read on ~35-70 ms
#: windows) and fading (1.5-2.5 s, a telegraph read on 0.46-0.63 s CPIs: one 40 s
#: flight holds only ~10-25 switches, so its own realised timescale scatters by ~25 %
#: and the variogram fit adds to that; the search stops at 4 s)
TIMESCALE_FACTOR = {"body_fluctuation": 2.0, "sideband_fading": 3.0}
SKIRT_DB = 1.5

FD = "sideband_fading"
BF = "body_fluctuation"
AS = "sideband_asymmetry"
LG = "motor_log_lag"
SC = "motor_speed_scale"
PN = "phase_noise"

ONE = [
    GenCase("as_l", 201, "gen_l", {AS: {"asymmetry_db": 4.0}}),
    GenCase("as_s", 202, "gen_s", {AS: {"asymmetry_db": -3.5}}),
    GenCase("fd_l", 203, "gen_l", {FD: {"fading_std_db": 4.0, "timescale_s": 1.5}}),
    GenCase("fd_s", 204, "gen_s", {FD: {"fading_std_db": 3.5, "timescale_s": 2.5}}),
    GenCase("bf005", 205, "gen_l", {BF: {"body_std_db": 4.0, "timescale_s": 0.05}}),
    GenCase("bf03", 206, "gen_s", {BF: {"body_std_db": 4.0, "timescale_s": 0.3}}),
    GenCase("bf1", 207, "gen_l", {BF: {"body_std_db": 3.5, "timescale_s": 1.0}}),
    GenCase("bf3", 208, "gen_l", {BF: {"body_std_db": 4.0, "timescale_s": 3.0}}),
    GenCase("lag_l", 209, "gen_l", {LG: {"lag_s": 0.5}}),
    GenCase("lag_s", 210, "gen_s", {LG: {"lag_s": -0.35}}),
    GenCase("sc_l", 211, "gen_l", {SC: {"scale": 1.07}}),
    GenCase("sc_s", 212, "gen_s", {SC: {"scale": 0.93}}),
    # a skirt that raises the floor near the clutter line also raises it under the
    # body: these flights are made 6 dB stronger to keep the body SNR >= 36 dB; at
    # gen_l the body flies at 20 m/s (167 Hz) to leave a floor clear of the target
    # within 35-95 Hz of the clutter line (see KNOWN_MISSES)
    GenCase("pn_gauss", 213, "gen_l", {PN: {"skirt_dbc_hz": -72.0, "shape": "gauss"}}, snr_db=46.0, speed_mps=20.0),
    GenCase("pn_flicker", 214, "gen_s", {PN: {"skirt_dbc_hz": -72.0, "shape": "flicker"}}, snr_db=46.0),
]
TWO = [
    GenCase("as_fd", 221, "gen_l", {AS: {"asymmetry_db": 4.0}, FD: {"fading_std_db": 4.0, "timescale_s": 2.0}}),
    GenCase("lag_sc", 222, "gen_s", {LG: {"lag_s": -0.4}, SC: {"scale": 1.07}}),
    GenCase(
        "bf_pn",
        223,
        "gen_l",
        {BF: {"body_std_db": 4.0, "timescale_s": 0.2}, PN: {"skirt_dbc_hz": -72.0, "shape": "gauss"}},
        snr_db=46.0,
        speed_mps=20.0,
    ),
    GenCase(
        "fd_bf",
        224,
        "gen_s",
        {FD: {"fading_std_db": 4.0, "timescale_s": 2.0}, BF: {"body_std_db": 3.5, "timescale_s": 0.1}},
    ),
    GenCase("as_lag", 225, "gen_l", {AS: {"asymmetry_db": -4.0}, LG: {"lag_s": 0.6}}),
    GenCase("sc_bf", 226, "gen_s", {SC: {"scale": 0.94}, BF: {"body_std_db": 4.5, "timescale_s": 0.5}}),
]
#: Phase noise with a sideband cause (issue 34): a 1/f-like skirt (to 400 Hz) lifts the
#: floor under the sidebands near the clutter line by up to ~20 dB, where the
#: raised-floor guard drops them, so that against the paper's model alone the fading
#: is not testable; with the named skirt in the floor's model it is judged on the pairs
#: the skirt leaves (``hypotheses.tests_given_skirt``). Before that, such flights were
#: reported as phase noise alone.
SKIRT = [
    GenCase(
        "pn_fd_skirt",
        242,
        "gen_s",
        {FD: {"fading_std_db": 4.0, "timescale_s": 1.5}, PN: {"skirt_dbc_hz": -64.0, "shape": "flicker"}},
        snr_db=52.0,
        speed_mps=16.0,
    )
]
CLEAN = [GenCase("clean_l", 231, "gen_l"), GenCase("clean_s", 232, "gen_s"), GenCase("clean_l2", 233, "gen_l")]
#: Known limit, kept as a strict xfail. pn_slow: at gen_l a body at ~80 Hz and its
#: first sidebands cover the whole 35-95 Hz band on both sides of the clutter line:
#: no floor clear of the target, so phase noise is not testable (the flight names
#: nothing).
KNOWN_MISSES = [GenCase("pn_slow", 213, "gen_l", {PN: {"skirt_dbc_hz": -72.0, "shape": "gauss"}}, snr_db=46.0)]


_RUNS: dict = {}


def run(case: GenCase):
    """(true effects, report entry) of the case, computed once per session."""
    if case.flight_id not in _RUNS:
        _RUNS[case.flight_id] = _run(case)
    return _RUNS[case.flight_id]


def _run(case: GenCase):
    flight, truth = make_flight(case)
    snr = float(np.nanmean(flight_body_snr_db(flight)))
    assert snr >= MIN_SNR_DB, f"{case.flight_id}: measured body SNR {snr:.1f} dB < {MIN_SNR_DB}"
    entry = diagnose_flight(flight, config={"figures": False})
    return truth["effects"], entry


def check_params(cause: str, truth: dict, fit: dict) -> None:
    def rel(k):
        assert abs(fit[k] - truth[k]) <= SIZE_REL * abs(truth[k]), (cause, k, truth[k], fit[k])

    def timescale():
        r = fit["timescale_s"] / truth["timescale_s"]
        f = TIMESCALE_FACTOR[cause]
        assert 1 / f <= r <= f, (cause, "timescale_s", truth["timescale_s"], fit["timescale_s"])

    if cause == AS:
        assert abs(fit["asymmetry_db"] - truth["asymmetry_db"]) <= 1.0, (truth, fit)
    elif cause == FD:
        rel("fading_std_db")
        timescale()
    elif cause == BF:
        rel("body_std_db")
        timescale()
    elif cause == LG:
        assert abs(fit["lag_s"] - truth["lag_s"]) <= 0.1, (truth, fit)
    elif cause == SC:
        assert abs((fit["scale"] - 1) - (truth["scale"] - 1)) <= SIZE_REL * abs(truth["scale"] - 1), (truth, fit)
    elif cause == PN:
        assert abs(fit["skirt_dbc_hz"] - truth["skirt_dbc_hz"]) <= SKIRT_DB, (truth, fit)
        assert fit["rms_rad"] > 0
    else:
        raise AssertionError(cause)


def _check_case(case: GenCase):
    effects, entry = run(case)
    named = [c["cause"] for c in entry["causes"]]
    fits = {c["cause"]: (c.get("extension") or c)["params"] for c in entry["causes"]}
    print(f"{case.flight_id}: truth {effects} named {named} fit {fits}")
    detail = json.dumps(
        {c: {k: t.get(k) for k in ("log_evalue", "relevant", "params")} for c, t in entry["evidence"]["tests"].items()}
    )
    assert set(named) == set(effects), f"{case.flight_id}: truth {sorted(effects)}, named {named}: {detail}"
    assert entry["cause"] == (named[0] if named else "none")
    for c in entry["causes"]:
        check_params(c["cause"], effects[c["cause"]], c["extension"]["params"])
        g = c["gain"]
        assert g["held_out"] is True and g["extended"] < g["baseline"], (c["cause"], g)
    # strongest first: held-out gain per observation, each with the others in both models
    gains = [c["gain"]["baseline"] - c["gain"]["extended"] for c in entry["causes"]]
    assert gains == sorted(gains, reverse=True)


@pytest.mark.parametrize("case", fast_loop(ONE, lambda c: False), ids=lambda c: c.flight_id)
def test_one_cause_is_named_with_its_parameters(case):
    _check_case(case)


@pytest.mark.slow
@pytest.mark.parametrize("case", fast_loop(TWO, lambda c: c.flight_id == "as_fd"), ids=lambda c: c.flight_id)
def test_two_causes_are_both_named_and_nothing_else(case):
    _check_case(case)
    _, entry = run(case)
    for c in entry["causes"]:
        others = sorted(set(case.effects) - {c["cause"]})
        assert c["evidence"]["other_causes_in_both_models"] == others


@pytest.mark.slow
@pytest.mark.parametrize("case", SKIRT, ids=lambda c: c.flight_id)
def test_sideband_cause_is_named_under_a_phase_noise_skirt(case):
    """Both causes named, with their parameters; the fading judged with the phase
    noise in both models (its pairs lie on the skirt: against the paper's model alone
    it is not testable). The 1/f-like skirt (to 400 Hz) is in the model as measured
    (the extension's ``skirt_profile``), so nothing is left ``unexplained``; with the
    catalog's flat skirt an excess 50-90 Hz from the body was."""
    effects, entry = run(case)
    named = [c["cause"] for c in entry["causes"]]
    assert set(named) == set(effects), (named, json.dumps(entry["evidence"]["steps"]))
    assert not entry["evidence"]["tests"][FD]["testable"]
    for c in entry["causes"]:
        check_params(c["cause"], effects[c["cause"]], c["extension"]["params"])
        assert c["gain"]["held_out"] is True and c["gain"]["extended"] < c["gain"]["baseline"], c
    fd = next(c for c in entry["causes"] if c["cause"] == FD)
    assert fd["evidence"]["other_causes_in_both_models"] == [PN]
    assert fd["evidence"]["phase_noise_skirt_in_floor_model"] is True
    assert FD not in entry["not_testable"]


def _flicker_case() -> tuple[GenCase, float]:
    """A 1/f-like skirt (the generator's, to 400 Hz) whose level is drawn from a seed
    the diagnosis never sees: U(-66, -60) dBc/Hz at 50 Hz."""
    level = float(np.random.default_rng(34_2029).uniform(-66.0, -60.0))
    return GenCase(
        "pn_flicker_shape", 215, "gen_l", {PN: {"skirt_dbc_hz": level, "shape": "flicker"}}, snr_db=54.0, speed_mps=16.0
    ), level


@pytest.mark.slow
def test_phase_noise_skirt_shape_is_measured_and_fits():
    """The phase-noise extension carries the skirt as measured (issue 34): a 1/f-like
    skirt reaches ~400 Hz, far beyond the catalog's flat 100 Hz band and the goodness
    of fit's clutter guard, where the flat model left +10-13 dB `unexplained` on every
    such flight of the evaluation plan. Now: phase noise named alone, no `unexplained`;
    the measured profile (:func:`microdoppler.diagnosis.measure.skirt_profile`) within
    2 dB of the generator's density in the 280-396 Hz band, and the band beyond its
    400 Hz edge (560-792 Hz) at least 10 dB lower. Measured (level -62.4 dBc/Hz, body
    SNR 37.4 dB): every band to 396 Hz within 1.1 dB of the generator's density
    (280-396 Hz: -70.4 for -70.3), none beyond 396 Hz. With the flat skirt (the code
    before) the flight reads `unexplained`."""
    case, level = _flicker_case()
    effects, entry = run(case)
    named = [c["cause"] for c in entry["causes"]]
    assert named == [PN], (named, entry["causes"][-1])
    prof = entry["causes"][0]["extension"]["params"]["skirt_profile"]
    edges, dbc = np.asarray(prof["band_edges_hz"]), np.asarray(prof["dbc_hz"])
    j = int(np.searchsorted(edges, 300.0) - 1)
    lo, hi = edges[j], edges[j + 1]
    # the generator's two-sided density 10^(level/10) x 55 / (f + 5) below 400 Hz, band mean
    truth = level + 10 * np.log10(55 * np.log((min(hi, 400) + 5) / (lo + 5)) / (hi - lo))
    assert abs(dbc[j] - truth) <= 2.0, (lo, hi, dbc[j], truth)
    k = int(np.searchsorted(edges, 600.0) - 1)
    assert k < len(dbc) and dbc[k] <= dbc[j] - 10.0, (edges.tolist(), dbc.tolist())


#: f0138 of the evaluation plan (``benchmarks/eval_diagnosis.py --seed 20261126``): a
#: Gaussian skirt, the body 52 Hz from the clutter line
PN_BY_CLUTTER = GenCase(
    "pn_body_by_clutter",
    1188059199,
    "gen_l",
    {PN: {"skirt_dbc_hz": -64.46, "shape": "gauss"}},
    duration_s=30.0,
    snr_db=50.9,
    speed_mps=6.26,
)


@pytest.mark.slow
def test_phase_noise_is_named_with_the_body_next_to_the_clutter_line():
    """With the body 52 Hz from the clutter line, the phase-noise test's 35-95 Hz
    ordinates lie on one side only, where the body-spread column takes up the skirt:
    log e-value 1.6, not named, the flight read `unexplained` (the code before). The
    wide-band reading of the measured skirt (35 Hz-1.2 kHz, both sides, far from the
    body; :func:`microdoppler.diagnosis.hypotheses.profile_skirt_test`) names it:
    measured log e-value 514, floor rise 4.95 dB in its innermost band (99-140 Hz;
    margin 3 dB), skirt -64.42 for -64.46 dBc/Hz."""
    effects, entry = run(PN_BY_CLUTTER)
    named = [c["cause"] for c in entry["causes"]]
    assert named == [PN], (named, entry["evidence"]["tests"][PN])
    c = entry["causes"][0]
    check_params(PN, effects[PN], c["extension"]["params"])
    assert c["evidence"]["profile_test"]["used"] is True
    assert c["gain"]["held_out"] is True and c["gain"]["extended"] < c["gain"]["baseline"]


@pytest.mark.parametrize("case", fast_loop(CLEAN, lambda c: False), ids=lambda c: c.flight_id)
def test_clean_flight_names_nothing(case):
    _check_case(case)
    _, entry = run(case)
    assert entry["cause"] == "none" and entry["causes"] == []


@pytest.mark.parametrize(
    "case",
    [
        pytest.param(c, marks=[pytest.mark.slow, pytest.mark.xfail(strict=True, reason="see KNOWN_MISSES")])
        for c in KNOWN_MISSES
    ],
    ids=lambda c: c.flight_id,
)
def test_known_misses(case):
    _check_case(case)


def test_cases_cover_the_catalog_both_radars_and_signs():
    from microdoppler.causes.catalog import CATALOG

    causes = {c for case in ONE for c in case.effects}
    # "unexplained" is no effect; blade_imbalance is hidden in tests/test_diagnosis_blades.py
    assert causes == set(CATALOG) - {"none", "unexplained", "blade_imbalance"}
    for cause in causes:
        assert {case.radar for case in ONE if cause in case.effects} == {"gen_l", "gen_s"}, cause
    signs = {
        (c, np.sign(p.get("asymmetry_db", p.get("lag_s", p.get("scale", 1) - 1))))
        for case in ONE + TWO
        for c, p in case.effects.items()
        if c in (AS, LG, SC)
    }
    assert {s for c, s in signs if c == AS} == {1.0, -1.0}
    assert {s for c, s in signs if c == LG} == {1.0, -1.0}
    assert {s for c, s in signs if c == SC} == {1.0, -1.0}
    taus = [p["timescale_s"] for case in ONE + TWO + KNOWN_MISSES for c, p in case.effects.items() if c == BF]
    assert min(taus) <= 0.05 and max(taus) >= 3.0


def test_generator_shares_no_code_with_the_emulator():
    """The generator imports numpy, scipy and the flight container only."""
    import ast
    from pathlib import Path

    src = (Path(__file__).parent / "independent_generator.py").read_text()
    mods = set()
    for node in ast.walk(ast.parse(src)):
        if isinstance(node, ast.Import):
            mods |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            mods.add(node.module)
    assert {m for m in mods if m.startswith("microdoppler")} == {"microdoppler.io.flightzarr"}, mods
    assert {m.split(".")[0] for m in mods} <= {"numpy", "scipy", "microdoppler", "__future__", "dataclasses"}, mods


@pytest.mark.parametrize("shape, timescale_s", [("exp", 0.05), ("exp", 0.3), ("crit", 1.0), ("exp", 3.0)])
def test_timescale_estimator_on_windowed_processes(shape, timescale_s):
    """:func:`~microdoppler.diagnosis.hypotheses.fit_gain_process` on a dB gain seen
    through 512-pulse Blackman-Harris windows (the body's short windows) plus noise:
    an exponential (AR(1), made here) or a critically damped process of the
    generator, 120 s. Size within 15 % of the path's own std, time within 30 % up to
    1 s and a factor 2 at 3 s (120 s hold only ~40 correlation times of 3 s)."""
    from scipy.signal import lfilter
    from scipy.signal.windows import blackmanharris

    from independent_generator import _crit_damped
    from microdoppler.diagnosis.hypotheses import fit_gain_process

    prf, nw, dur, sd = 7300.0, 512, 120.0, 4.0
    rng = np.random.default_rng(int(timescale_s * 1000))
    dt = 0.002
    m = int(dur / dt)
    if shape == "exp":
        a = np.exp(-dt / timescale_s)
        w0 = rng.standard_normal(m) * sd * np.sqrt(1 - a * a)
        w0[0] = rng.standard_normal() * sd
        x = lfilter([1.0], [1.0, -a], w0)
    else:
        x = _crit_damped(m, dt, sd, timescale_s, rng)
    t = np.arange(int(dur * prf)) / prf
    g = 10 ** (np.interp(t, dt * np.arange(m), x) / 10)
    win = blackmanharris(nw, sym=False)
    starts = np.arange(0, len(t) - nw, nw // 2)
    p = np.array([np.dot(g[i : i + nw], win**2) for i in starts]) / np.sum(win**2)
    y = 10 * np.log10(p) + rng.normal(0, 0.2, len(p))
    r = fit_gain_process(y, np.ones(len(y), bool), np.full(len(y), 0.04), nw / 2 / prf, win, prf, drift=False)
    assert abs(r["sigma_db"] - x.std()) <= 0.15 * x.std(), (r["sigma_db"], x.std())
    tol = 1.3 if timescale_s <= 1.0 else 2.0
    assert abs(np.log(r["timescale_s"] / timescale_s)) <= np.log(tol), (r["timescale_s"], timescale_s)
