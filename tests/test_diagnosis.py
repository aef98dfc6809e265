"""Tests of the diagnosis (issue 6): hidden effects, skipped flights, the report
(``diagnosis-report/2``), held-out gains, config validation, aggregation.

Hidden-effect tests use a fixed list of seeded cases (:data:`CASES`): every catalog
cause, both radars, both signs of the signed causes, and clean flights on both
radars. A case's seed draws the effect's magnitude (in the catalog's detectable
range) and the 40 s flight (measured body SNR after the STFT >= 36 dB); the
diagnosis sees the flight only (its id is neutral), never the seed or the truth.
Fresh random draws are in ``benchmarks/eval_diagnosis.py`` (not in CI).
"""

import json
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from conftest import fast_loop
from microdoppler.causes.catalog import CATALOG, CAUSES
from microdoppler.diagnosis import DiagnosisConfig, aggregate, decide, diagnose, diagnose_flight, measure, run_tests
from microdoppler.diagnosis import hypotheses as C
from microdoppler.diagnosis.measure import usable_pairs
from microdoppler.diagnosis.pipeline import REPORT_SCHEMA, split_settings
from microdoppler.emulator.world import FlightSpec, emulate_flight, measured_snr_db
from microdoppler.errors import ConfigError, InputError
from microdoppler.io.flightzarr import Flight, write_flight

REPO = Path(__file__).resolve().parents[1]
MIN_SNR_DB = 36.0  # the condition on the hidden-effect flights
MIN_PN_RISE_DB = 6.0  # the catalog's detectable phase noise: floor near clutter raised >= 6 dB
#: sideband_fading's timescale_s within this factor of the truth (see _check_param)
TIMESCALE_FACTOR = 3.0


@dataclass(frozen=True)
class Case:
    cause: str
    radar_id: str
    sign: int  # +1 / -1 for the signed causes (asymmetry_db, lag_s, scale - 1), 0 otherwise
    seed: int


CASES = [
    Case("sideband_asymmetry", "radar1", +1, 101),
    Case("sideband_asymmetry", "radar2", -1, 102),
    Case("sideband_fading", "radar1", 0, 115),
    Case("sideband_fading", "radar2", 0, 104),
    Case("sideband_fading", "radar1", 0, 103),
    Case("body_fluctuation", "radar1", 0, 105),
    Case("body_fluctuation", "radar2", 0, 106),
    Case("motor_log_lag", "radar2", +1, 107),
    Case("motor_log_lag", "radar1", -1, 108),
    Case("motor_speed_scale", "radar1", +1, 109),
    Case("motor_speed_scale", "radar2", -1, 110),
    Case("phase_noise", "radar1", 0, 116),
    Case("phase_noise", "radar1", 0, 111),
    Case("phase_noise", "radar2", 0, 112),
    Case("none", "radar1", 0, 113),
    Case("none", "radar2", 0, 114),
]
#: seeded flights the diagnosis gets wrong, kept as strict xfails so they are seen.
#: (Case 103, a Matrice 300 whose body Doppler is within 100 Hz of the clutter line, was
#: one until issue 12: only one sideband pair had both sides above the noise, so the
#: fading test was not testable; the fading test now counts a pair by its summed
#: power, it is testable and named, and the case is in CASES.)
#: Case 111 (phase noise, radar 1, a Matrice 300 at a measured body SNR of 36.0 dB,
#: the threshold) was one with the emulator's world v2 (sideband fall-off 4-16 dB
#: per harmonic; this flight's is 11.3 dB): a spurious white body_fluctuation was
#: named second (0.69 dB over the measurement noise, timescale at its 0.01 s bound).
#: The body power's noise was that of independent bins at the far floor; it now is
#: that of the floor around the body (raised by the phase noise's skirt of the
#: clutter line) through the window's bin correlation (measure.body_floor_ratio,
#: measure.noise_power_factor), and the case is in CASES.
KNOWN_MISSES: list = []
#: the cases of the fast loop (``-m "not slow"``): one cause and a clean flight
FAST_SEEDS = (101, 113)


def test_cases_cover_the_catalog_radars_and_signs():
    # "unexplained" is no effect to hide; blade_imbalance is hidden by the emulator's
    # airframes (a population effect) and by tests/test_diagnosis_blades.py
    emulated = [c for c in CATALOG if c not in ("unexplained", "blade_imbalance")]
    assert {c.cause for c in CASES} == set(emulated)
    for cause in emulated:
        assert {c.radar_id for c in CASES if c.cause == cause} == {"radar1", "radar2"}, cause
    for cause in ("sideband_asymmetry", "motor_log_lag", "motor_speed_scale"):
        assert {c.sign for c in CASES if c.cause == cause} == {1, -1}, cause
    assert len({c.seed for c in CASES}) == len(CASES)


def draw_effect(cause: str, sign: int, rng: np.random.Generator) -> dict:
    """A magnitude in the catalog's detectable range, with the case's sign."""
    return {
        "none": lambda: {},
        "sideband_asymmetry": lambda: {"asymmetry_db": sign * rng.uniform(3, 6)},
        "sideband_fading": lambda: {"fading_std_db": rng.uniform(3, 6), "timescale_s": rng.uniform(1, 2)},
        "body_fluctuation": lambda: {"body_std_db": rng.uniform(3, 6)},
        "motor_log_lag": lambda: {"lag_s": sign * rng.uniform(0.3, 1.0)},
        "motor_speed_scale": lambda: {"scale": 1 + sign * rng.uniform(0.05, 0.12)},
        "phase_noise": lambda: {"rms_rad": rng.uniform(0.006, 0.02)},
    }[cause]()


def _near_clutter_rise_db(flight) -> float:
    """Floor within 35-95 Hz of the clutter line: flight over background [dB]."""
    from microdoppler.diagnosis.measure import stft_power

    a = stft_power(flight.iq, flight.prf_hz, 4096)
    b = stft_power(flight.background_iq, flight.prf_hz, 4096)
    sel = (np.abs(a.f_hz) > 35) & (np.abs(a.f_hz) < 95)
    return float(10 * np.log10(np.median(a.p[:, sel]) / np.median(b.p[:, sel])))


@lru_cache(maxsize=None)
def emulate(case: Case):
    """The case's 40 s flight: (flight, truth params, spec). The seed draws the effect
    and the flight; a flight whose measured body SNR is below 36 dB (a body near the
    clutter notch much of the flight, or radar2's raised floor) is redrawn with the
    nominal SNR raised by the shortfall; phase noise is rescaled until the floor near
    clutter rises >= 6 dB. Both targets are asserted."""
    rng = np.random.default_rng(case.seed)
    params = draw_effect(case.cause, case.sign, rng)
    effects = {case.cause: params} if params else {}
    snr_db, snrs = 42.0, []
    for _ in range(6):
        spec = FlightSpec(
            "hidden",
            "drone",
            drone_model=str(rng.choice(["inspire2", "matrice300"])),
            radar_id=case.radar_id,
            duration_s=40.0,
            mean_range_m=float(rng.uniform(1000, 2500)),
            speed_mps=float(rng.uniform(3, 12)),
            direction=int(rng.choice([1, -1])),
            snr_db=snr_db,
            effects=effects,
            seed=int(rng.integers(2**31)),
        )
        flight, _ = emulate_flight(spec)
        snrs.append(measured_snr_db(flight)[0])
        if snrs[-1] >= MIN_SNR_DB:
            break
        snr_db += MIN_SNR_DB + 0.5 - snrs[-1]
    assert snrs[-1] >= MIN_SNR_DB, f"{case}: no draw reached a measured body SNR of {MIN_SNR_DB} dB: {snrs}"
    if case.cause == "phase_noise":
        rises = [_near_clutter_rise_db(flight)]
        for _ in range(4):
            if rises[-1] >= MIN_PN_RISE_DB:
                break
            params = {"rms_rad": params["rms_rad"] * 10 ** ((8.0 - rises[-1]) / 20)}
            spec = replace(spec, effects={case.cause: params})
            flight, _ = emulate_flight(spec)
            rises.append(_near_clutter_rise_db(flight))
        assert rises[-1] >= MIN_PN_RISE_DB, f"{case}: phase-noise floor rise {rises} dB never reached 6 dB"
        assert measured_snr_db(flight)[0] >= MIN_SNR_DB
    return flight, params, spec


def _check_param(cause, truth, fit):
    k = CAUSES[cause].main_param
    t, f = truth[k], fit[k]
    if cause == "motor_log_lag":
        assert abs(f - t) <= 0.1, (k, t, f)
    elif cause == "motor_speed_scale":
        assert abs((f - 1) - (t - 1)) <= 0.3 * abs(t - 1), (k, t, f)
    else:
        assert abs(f - t) <= 0.3 * abs(t), (k, t, f)
    if cause == "body_fluctuation":
        # the emulator's default correlation time when the case does not set one
        r = fit["timescale_s"] / truth.get("timescale_s", 0.3)
        assert 0.5 <= r <= 2.0, ("timescale_s", truth.get("timescale_s", 0.3), fit["timescale_s"])
    if cause == "sideband_fading":
        # timescale_s comes from the lag-2-CPI autocorrelation of the common-mode
        # blade power on one 40 s flight (~13 correlation times of 1.5 s), clipped to
        # 0.5-4 s. Measured on 59 emulated flights (truth 1-2 s, 3-6 dB): median
        # fit/truth 0.83, 73 % within a factor 2, 92 % within 3, all within 4 (the
        # clip). The factor 3 catches gross errors (e.g. a lag in CPIs, 0.28 s, read as s).
        r = fit["timescale_s"] / truth["timescale_s"]
        assert 1 / TIMESCALE_FACTOR <= r <= TIMESCALE_FACTOR, ("timescale_s", truth["timescale_s"], fit["timescale_s"])


def _case_id(c: Case) -> str:
    return f"{c.cause}-{c.radar_id}-{'+-0'[[1, -1, 0].index(c.sign)]}-{c.seed}"


@pytest.mark.slow
@pytest.mark.parametrize(
    "case",
    [
        *fast_loop(CASES, lambda c: c.seed in FAST_SEEDS),
        *(pytest.param(c, marks=pytest.mark.xfail(strict=True, reason="see KNOWN_MISSES")) for c in KNOWN_MISSES),
    ],
    ids=_case_id,
)
def test_hidden_effect_is_named_with_its_parameter(case):
    flight, params, spec = emulate(case)
    entry = diagnose_flight(flight, config={"figures": False})  # sees the flight only
    fit = entry["causes"][0]["extension"]["params"] if entry["causes"] else {}
    print(
        f"{case.cause} {case.radar_id} sign={case.sign:+d} seed={case.seed} {spec.drone_model}: "
        f"truth {params} fit {fit} named {entry['cause']}"
    )
    detail = (
        f"hidden {case.cause} {params} ({spec.radar_id}, {spec.drone_model}), named {entry['cause']}: "
        f"{json.dumps(entry['evidence']['tests'])[:1500]}"
    )
    assert entry["cause"] == case.cause, detail
    if case.cause == "none":
        assert entry["causes"] == []
        return
    (c,) = entry["causes"]
    assert c["cause"] == c["extension"]["name"] == case.cause
    # the catalog's parameters, and a phase noise's measured skirt where it could be read
    extra = {"skirt_profile"} if case.cause == "phase_noise" else set()
    assert set(c["extension"]["params"]) - extra == {p.name for p in CAUSES[case.cause].params}
    _check_param(case.cause, params, c["extension"]["params"])
    g = c["gain"]
    assert g["held_out"] is True and g["extended"] < g["baseline"], g


#: weak-blade imbalances for the emulated flights below, drawn in the issue's 3-10 dB from
#: a seed the diagnosis never sees
_IMB_DRAW = np.random.default_rng(34_2026)
EMULATED_IMBALANCES_DB = [float(x) for x in _IMB_DRAW.uniform(3.0, 10.0, 2)]


@pytest.mark.slow
@pytest.mark.parametrize(
    "model, imb, seed", [("matrice300", EMULATED_IMBALANCES_DB[0], 321), ("inspire2", EMULATED_IMBALANCES_DB[1], 322)]
)
def test_emulated_weak_blade_is_named(model, imb, seed):
    """The emulator's weak blade (a population effect of the worlds' airframes): the
    rotation-rate lines sit between the target's own lines, whose skirts lift their local
    floor 5-30 dB, and the blade-imbalance test used to read none of them (0 of 102
    CPIs, issue 34). Named, with imbalance_db within the issue's 1.5 dB."""
    spec = FlightSpec(
        "weak",
        "drone",
        drone_model=model,
        radar_id="radar2",
        duration_s=30.0,
        snr_db=54.0,
        speed_mps=8.0,
        path="straight",
        effects={"blade_imbalance": {"imbalance_db": imb}},
        seed=seed,
        airframe=f"{model}-weak",
    )
    flight, _ = emulate_flight(spec)
    assert measured_snr_db(flight)[0] >= MIN_SNR_DB
    entry = diagnose_flight(flight, config={"figures": False})
    named = {c["cause"]: c for c in entry["causes"]}
    assert "blade_imbalance" in named, (entry["causes"], entry["not_testable"])
    fit = named["blade_imbalance"]["extension"]["params"]["imbalance_db"]
    assert abs(fit - imb) <= 1.5, (fit, imb)
    # nothing else: with the imbalance's rotation lines in the sidebands' floor model
    # the paper's model is calibrated and fits (before, the Matrice read a spurious
    # fading and unexplained at 8 dB)
    assert list(named) == ["blade_imbalance"], (list(named), entry["evidence"]["goodness_of_fit"])


#: a weak blade seen in few clear CPIs, drawn from a seed the diagnosis never sees
WEAK_FEW_CPIS_DB = float(np.random.default_rng(34_2032).uniform(3.0, 6.0))


@pytest.mark.slow
def test_weak_blade_in_few_clear_cpis_is_named():
    """A Matrice 300 at ~2 km (issue 34's plan, f0253's geometry): its blade-passing
    lines stand clear on both sides of a non-multiple order in 14 CPIs only, and the
    imbalance test, asking for 16 (two blocks), was not testable: ``unexplained`` at
    ~26 dB on the rotation-rate lines. One block with both folds is enough (no
    spurious imbalance on 402 balanced flights of the two plans): named, within 1.5 dB,
    nothing else."""
    spec = FlightSpec(
        "weak",
        "drone",
        drone_model="matrice300",
        radar_id="radar2",
        duration_s=30.0,
        mean_range_m=1973.5,
        height_m=100.0,
        speed_mps=8.48,
        direction=1,
        snr_db=52.9,
        effects={"blade_imbalance": {"imbalance_db": WEAK_FEW_CPIS_DB}},
        seed=1735387784,
        airframe="matrice300-weak",
    )
    flight, _ = emulate_flight(spec)
    entry = diagnose_flight(flight, config={"figures": False})
    assert [c["cause"] for c in entry["causes"]] == ["blade_imbalance"], (entry["causes"], entry["not_testable"])
    fit = entry["causes"][0]["extension"]["params"]["imbalance_db"]
    assert abs(fit - WEAK_FEW_CPIS_DB) <= 1.5, (fit, WEAK_FEW_CPIS_DB)


#: a strong blade fading, drawn from a seed the diagnosis never sees
_FADE_DRAW = np.random.default_rng(34_2031)
STRONG_FADING = {
    "fading_std_db": float(_FADE_DRAW.uniform(5.0, 6.5)),
    "timescale_s": float(_FADE_DRAW.uniform(1.2, 2.0)),
}


def _strong_fading_entry(seed: int) -> dict:
    spec = FlightSpec(
        "fade",
        "drone",
        drone_model="inspire2",
        radar_id="radar1",
        duration_s=30.0,
        snr_db=54.0,
        speed_mps=8.0,
        path="straight",
        effects={"sideband_fading": STRONG_FADING},
        seed=seed,
    )
    flight, _ = emulate_flight(spec)
    entry = diagnose_flight(flight, config={"figures": False})
    assert [c["cause"] for c in entry["causes"]] == ["sideband_fading"], (entry["causes"], STRONG_FADING)
    fit = entry["causes"][0]["extension"]["params"]["fading_std_db"]
    assert abs(fit / STRONG_FADING["fading_std_db"] - 1) <= 0.2, (fit, STRONG_FADING)
    return entry


@pytest.mark.slow
def test_emulated_fading_that_moves_the_body_line_is_a_fading():
    """The blades' mean return lies on the body Doppler, so a strong blade fading moves
    the body line too: on this flight the common sideband power correlates with the
    body's at r > 0.7, which read as a gain on the whole target (a range straddle,
    ``unexplained``) and the fading went unnamed (6 catalog-only flights of issue 34's
    two plans). The body moves by a fraction of the sidebands' dB only
    (``body_share`` below ``DiagnosisConfig.common_gain_body_share``; a straddle moves both alike):
    the fading is named, with its size, and nothing else."""
    ev = _strong_fading_entry(341)["causes"][0]["evidence"]
    cfg = DiagnosisConfig()
    assert ev["body_correlation"] > cfg.common_gain_corr and ev["body_share"] < cfg.common_gain_body_share, ev


@pytest.mark.slow
def test_named_fading_does_not_spread_the_blades_mean_return():
    """The goodness of fit's model took the blades' mean return out after the fading's
    gain had spread it: a skirt 20 dB above the sidebands' floor, beyond half the
    rotation rate from the body, that the measured flight does not have (the model
    8-14 dB too high 40-80 Hz below the body, ``unexplained`` beside the named fading).
    The gain now acts on the blades without their mean return: the fading alone."""
    g = _strong_fading_entry(343)["evidence"]["goodness_of_fit"]
    assert not g["excess"] and g["largest_significant_db"] < 7.0, g


#: a weak blade with a sideband asymmetry, drawn from a seed the diagnosis never sees
_IMB_ASY_DRAW = np.random.default_rng(34_2027)
IMB_ASY = (
    float(_IMB_ASY_DRAW.uniform(3.0, 10.0)),
    float(_IMB_ASY_DRAW.choice([-1, 1]) * _IMB_ASY_DRAW.uniform(3.0, 6.0)),
)


@pytest.mark.slow
@pytest.mark.parametrize("model, radar, seed", [("matrice300", "radar1", 331), ("matrice300", "radar2", 333)])
def test_weak_blade_with_asymmetry_both_named(model, radar, seed):
    """A weak blade's rotation lines lift the local floor of every HERM sideband (half
    a line spacing away for two blades): the sidebands' raised-floor guard dropped
    them all, the asymmetry was not testable and the model was calibrated on no pair
    (unexplained at 19-30 dB on these flights). With a named imbalance in the floor's
    model (:func:`.measure.given_imbalance`) both causes are named, each parameter
    recovered, and the model with both extensions fits."""
    imb, asy = IMB_ASY
    spec = FlightSpec(
        "weak",
        "drone",
        drone_model=model,
        radar_id=radar,
        duration_s=30.0,
        snr_db=54.0,
        speed_mps=8.0,
        path="straight",
        seed=seed,
        airframe=f"{model}-weak",
        effects={"blade_imbalance": {"imbalance_db": imb}, "sideband_asymmetry": {"asymmetry_db": asy}},
    )
    flight, _ = emulate_flight(spec)
    assert measured_snr_db(flight)[0] >= MIN_SNR_DB
    entry = diagnose_flight(flight, config={"figures": False})
    named = {c["cause"]: c["extension"]["params"] if c.get("extension") else c["params"] for c in entry["causes"]}
    assert set(named) == {"blade_imbalance", "sideband_asymmetry"}, (named, entry["not_testable"])
    assert abs(named["blade_imbalance"]["imbalance_db"] - imb) <= 1.5, (named, imb)
    assert abs(named["sideband_asymmetry"]["asymmetry_db"] - asy) <= 1.0, (named, asy)
    asym = next(c for c in entry["causes"] if c["cause"] == "sideband_asymmetry")
    assert asym["evidence"]["other_causes_in_both_models"] == ["blade_imbalance"], asym["evidence"]


@pytest.mark.slow
@pytest.mark.parametrize(
    "effects, seed",
    [
        ({"sideband_asymmetry": {"asymmetry_db": -4.5}, "motor_log_lag": {"lag_s": 0.6}}, 301),
        ({"body_fluctuation": {"body_std_db": 4.0, "timescale_s": 0.8}, "motor_speed_scale": {"scale": 1.08}}, 302),
    ],
)
def test_two_emulated_causes_are_both_named(effects, seed):
    """Two causes at once: both named, nothing else, each parameter recovered, each
    gain held out with the other cause's extension in both models."""
    spec = FlightSpec(
        "two",
        "drone",
        drone_model="inspire2",
        radar_id="radar1",
        duration_s=40.0,
        snr_db=44.0,
        speed_mps=9.0,
        path="straight",
        effects=effects,
        seed=seed,
    )
    flight, truth = emulate_flight(spec)
    assert measured_snr_db(flight)[0] >= MIN_SNR_DB
    entry = diagnose_flight(flight, config={"figures": False})
    named = [c["cause"] for c in entry["causes"]]
    assert set(named) == set(effects), (named, json.dumps(entry["evidence"]["steps"])[:1500])
    for c in entry["causes"]:
        k = CAUSES[c["cause"]].main_param
        t, f = truth["effects"][c["cause"]][k], c["extension"]["params"][k]
        tol = {"lag_s": 0.1, "asymmetry_db": 1.0, "scale": 0.2 * abs(t - 1)}.get(k, 0.2 * abs(t))
        assert abs(f - t) <= tol, (k, t, f)
        assert c["evidence"]["other_causes_in_both_models"] == sorted(set(effects) - {c["cause"]})
        assert c["gain"]["held_out"] and c["gain"]["extended"] < c["gain"]["baseline"]
    steps = entry["evidence"]["steps"]
    by_step = sorted(entry["causes"], key=lambda c: c["evidence"]["named_at_step"])
    assert [s["named"] for s in steps] == [c["cause"] for c in by_step] + ["none"]
    assert steps[1]["given"] == [by_step[0]["cause"]]
    assert steps[0]["log_evalue_threshold"] < steps[1]["log_evalue_threshold"] < steps[2]["log_evalue_threshold"]


@pytest.mark.slow
@pytest.mark.parametrize("timescale_s, seed, duration_s", [(0.08, 311, 40.0), (1.2, 312, 120.0)])
def test_body_size_and_timescale_away_from_the_default(timescale_s, seed, duration_s):
    """Issue 12: with the correlation time assumed (0.3 s) the body_std_db of flights
    whose true time differs came out 35-54 % low. Estimated jointly now: size within
    20 %, time within a factor 2. (A 1.2 s process's own std over 40 s scatters by
    ~17 % around its nominal value: that flight is 120 s long.)"""
    effects = {"body_fluctuation": {"body_std_db": 4.5, "timescale_s": timescale_s}}
    spec = FlightSpec(
        "bt",
        "drone",
        drone_model="inspire2",
        radar_id="radar1",
        duration_s=duration_s,
        snr_db=44.0,
        speed_mps=9.0,
        path="straight",
        effects=effects,
        seed=seed,
    )
    flight, _ = emulate_flight(spec)
    assert measured_snr_db(flight)[0] >= MIN_SNR_DB
    entry = diagnose_flight(flight, config={"figures": False})
    assert [c["cause"] for c in entry["causes"]] == ["body_fluctuation"]
    p = entry["causes"][0]["extension"]["params"]
    assert abs(p["body_std_db"] - 4.5) <= 0.2 * 4.5, p
    assert 0.5 <= p["timescale_s"] / timescale_s <= 2.0, p


@pytest.mark.slow
@pytest.mark.parametrize(
    "radar_id, drone_model, seed",
    fast_loop([("radar1", "matrice300", 4711), ("radar2", "inspire2", 4712)], lambda v: v[0] == "radar1"),
)
def test_steep_sideband_falloff_clean_flight_names_no_cause(radar_id, drone_model, seed):
    """World v2: a large drone whose sidebands fall off by 14 dB per harmonic (one or
    two pairs visible) and that has no effect gets no cause. Before the fading
    test took the paper's envelope tilt by the rotor speed out of the harmonics
    (``hypotheses.envelope_tilt``), such flights showed a held-out fading log e-value
    of 10-40 (threshold ~7; 42 and 23 on these two) and, where the size estimate
    reached the 2 dB margin, a spurious sideband_fading of 2.0-2.7 dB."""
    snr_db, snrs = 44.0, []
    for _ in range(4):
        spec = FlightSpec(
            "steep",
            "drone",
            drone_model=drone_model,
            radar_id=radar_id,
            duration_s=40.0,
            mean_range_m=1800.0,
            speed_mps=8.0,
            snr_db=snr_db,
            harmonic_falloff_db=14.0,
            seed=seed,
        )
        flight, truth = emulate_flight(spec)
        snrs.append(measured_snr_db(flight)[0])
        if snrs[-1] >= MIN_SNR_DB:
            break
        snr_db += MIN_SNR_DB + 0.5 - snrs[-1]
    assert snrs[-1] >= MIN_SNR_DB, snrs
    assert truth["harmonic_falloff_db"] == 14.0
    entry = diagnose_flight(flight, config={"figures": False})
    tests = entry["evidence"]["tests"]
    assert tests["sideband_fading"]["testable"], tests["sideband_fading"]  # the fading test did run
    assert entry["cause"] == "none" and entry["causes"] == [], json.dumps(entry["evidence"]["steps"])[:1500]
    assert tests["sideband_fading"]["log_evalue"] < entry["evidence"]["log_evalue_threshold"]


@pytest.mark.slow
def test_gain_is_scored_on_held_out_folds():
    """The reported gain of a named cause is the held-out NLL: recomputed here from
    the test's per-CPI statistic, fitting on one fold and scoring on the other; the
    in-sample NLL of the extension differs (lower), so the values are out-of-sample."""
    case = CASES[0]
    flight, _, _ = emulate(case)
    cfg = DiagnosisConfig(figures=False)
    entry = diagnose_flight(flight, config=cfg)
    (c,) = entry["causes"]
    M = measure(flight, None, cfg)
    t = run_tests(M, cfg).tests[case.cause]
    d = t.series["stat"]
    fold = C.folds(len(M.t_s), cfg.block_cpis)[np.isin(M.t_s, t.series["t_s"])]
    nb = ne = 0.0
    for k in (0, 1):
        tr, te = d[fold == k], d[fold != k]
        mu, vb, ve = tr.mean(), np.mean(tr**2) + 1e-6, tr.var() + 1e-6
        nb += np.sum(0.5 * (np.log(2 * np.pi * vb) + te**2 / vb))
        ne += np.sum(0.5 * (np.log(2 * np.pi * ve) + (te - mu) ** 2 / ve))
    assert c["gain"]["baseline"] == pytest.approx(nb / len(d), abs=1e-3)
    assert c["gain"]["extended"] == pytest.approx(ne / len(d), abs=1e-3)
    in_sample = np.mean(0.5 * (np.log(2 * np.pi * (d.var() + 1e-6)) + (d - d.mean()) ** 2 / (d.var() + 1e-6)))
    assert in_sample < c["gain"]["extended"] - 1e-3
    assert c["gain"]["held_out"] is True and t.held_out


def _skirt_ordinates(level_per_hz, contaminated, seed):
    """Floor ordinates as :func:`microdoppler.diagnosis.measure.skirt_ordinates`
    gives them: exponential periodogram bins on a background S = 1 in 5 bands of
    offset, a clutter line 1e9 x bin width, a skirt ``level_per_hz`` flat over the
    bands; a share ``contaminated`` of them carries a line 100 x the floor."""
    rng = np.random.default_rng(seed)
    nb, n = 5, 4000
    jc = rng.integers(0, nb, n)
    A = np.column_stack([np.full(n, 1e9), np.zeros(n)])
    mean = 1.0 + A[:, 0] * level_per_hz
    line = rng.uniform(size=n) < contaminated
    P = rng.exponential(mean) + np.where(line, 100.0 * rng.exponential(1.0, n), 0.0)
    return {
        "P": P,
        "S": np.ones(n),
        "A": A,
        "jc": jc,
        "jb": np.full(n, nb),
        "cpi": np.arange(n) % 40,
        "pos": np.arange(n) % 2 == 0,
        "f_rel_body_hz": np.full(n, 500.0),
        "edges": 35.0 * np.sqrt(2) ** np.arange(nb + 1),
        "nb": nb,
        "counts": np.bincount(jc, minlength=nb),
        "fitted": np.ones(nb, bool),
    }


def test_skirt_levels_by_medians_are_robust_to_the_targets_lines():
    """The skirt's band levels come from medians, so lines among a fifth of the
    ordinates (the target's, where the model misplaces them) move a true 10 dB skirt
    up by 1.3-1.6 dB (theory +1.6 dB: the clean ordinates' 37.5 % quantile is read as
    their median; tolerance 2 dB), and with no skirt leave a level below the floor
    (0.33-0.44 of it, theory 0.42: a floor rise of 1.5 dB, under the 3 dB margin;
    a mean-based fit reads +13 dB); the wide-band test finds 10 dB with the skirt."""
    from microdoppler.diagnosis.hypotheses import profile_skirt_test
    from microdoppler.diagnosis.measure import robust_skirt_levels

    fold = (np.arange(40) // 4) % 2
    d = _skirt_ordinates(1e-8, 0.2, 1)  # skirt 10 x the floor
    lev = robust_skirt_levels(d)
    assert np.all(np.abs(10 * np.log10(lev * 1e9 / 10.0)) < 2.0), lev
    assert profile_skirt_test(d, fold)["rise_db"] > 9.0
    d0 = _skirt_ordinates(0.0, 0.2, 2)  # no skirt, the same lines
    assert 10 * np.log10(np.mean(d0["P"])) > 12.0  # what a mean would see
    lev0 = robust_skirt_levels(d0)
    assert np.all(lev0 * 1e9 < 0.5), lev0  # theory 0.42 of the floor
    assert profile_skirt_test(d0, fold)["rise_db"] < 3.0


def test_crossfit_held_out_only_with_two_folds():
    x = np.random.default_rng(3).normal(1.0, 1.0, 40)

    def fit(sel):
        return x[sel].mean() if sel.any() else np.nan

    def score(mu, sel):
        return -0.5 * x[sel] ** 2, -0.5 * (x[sel] - mu) ** 2

    two = C.CauseTest("t")
    C._crossfit(C.folds(40, 8), fit, score, two)
    assert two.held_out and two.n_obs == 40 and two.nll_ext < two.nll_base
    one = C.CauseTest("t")
    C._crossfit(np.zeros(40, int), fit, score, one)  # one fold empty: nothing held out
    assert not one.held_out
    # only held-out likelihood ratios are e-values: a test without them is never named
    strong = C.CauseTest("sideband_asymmetry", log_e=50.0, n_obs=40, relevant=True, held_out=True)
    assert decide({"sideband_asymmetry": strong}, DiagnosisConfig())[0] == "sideband_asymmetry"
    assert decide({"sideband_asymmetry": replace(strong, held_out=False)}, DiagnosisConfig())[0] == "none"


def test_fading_fit_borrowing_outside_its_fold_is_not_held_out():
    """The fading test's baseline scatter needs CPIs with >= 2 harmonics in the
    fitted fold; when a fold has none it uses the whole flight: not held out."""
    from types import SimpleNamespace

    n, cfg = 64, DiagnosisConfig(figures=False)
    fold = C.folds(n, cfg.block_cpis)
    rng = np.random.default_rng(5)

    def meas(ok):
        up = 100 * 10 ** (rng.normal(0, 0.3, (n, 3)) / 10)
        lo = 100 * 10 ** (rng.normal(0, 0.3, (n, 3)) / 10)
        sd = np.ones((n, 3))
        return SimpleNamespace(
            up=up,
            lo=lo,
            up_sd=sd,
            lo_sd=sd,
            pair_ok=ok,
            usable_pair_sums=usable_pairs(up, lo, sd, sd, ok, summed=True),
            valid=np.ones(n, bool),
            t_s=0.28 * np.arange(n),
            range_m=np.full(n, 1500.0),
            harm=np.arange(1, 4),
            f_log_hz=np.full(n, 80.0),
            model_h=np.ones((n, 3)),
            dil=np.ones(n),
            dil_ok=np.ones(n, bool),
            stft=SimpleNamespace(window=np.hanning(4096)),
            info={"prf_hz": 7300.0, "n_blades": 2},
        )

    everywhere = np.ones((n, 3), bool)
    one_fold = everywhere.copy()
    one_fold[fold == 1, 1:] = False  # fold 1: one harmonic per CPI only
    assert C.test_fading(meas(everywhere), cfg, fold).held_out
    t = C.test_fading(meas(one_fold), cfg, fold)
    assert t.testable and not t.held_out


def _ar1(rng, n, dt, sd, tau_s):
    from scipy.signal import lfilter

    a = np.exp(-dt / tau_s)
    w = rng.standard_normal(n) * sd * np.sqrt(1 - a * a)
    w[0] = rng.standard_normal() * sd
    return lfilter([1.0], [1.0, -a], w)


def test_fading_estimate_takes_out_the_rotor_speed_tilt():
    """A fading (dB Ornstein-Uhlenbeck, 4 dB, 1.5 s) common to 4 harmonics, each with
    its own beating-like fluctuation (1.5 dB, 0.3 s, independent between harmonics)
    and the envelope's tilt n beta u(t) from a rotor-speed wander u (4 rev/s, 0.6 s),
    seen through Blackman-Harris CPIs, 600 s. The tilt's slope comes out right even
    when the fading itself is correlated with the speed (it cancels in the
    harmonics' deviations from their mean); the fading's size and time are within
    15 % / 20 % of the same fit on the CPI-averaged fading alone, while without the
    speed (a constant log) the time comes out more than 25 % short."""
    from types import SimpleNamespace

    from scipy.signal.windows import blackmanharris

    from microdoppler.diagnosis.hypotheses import harmonic_speed_slope
    from microdoppler.diagnosis.measure import cpi_average

    rng = np.random.default_rng(20261123)
    prf, n_fft, dur, dt, beta = 14600.0, 4096, 600.0, 0.01, -0.25
    win = blackmanharris(n_fft, sym=False)
    tt = dt * np.arange(int(dur / dt))
    fad = _ar1(rng, len(tt), dt, 4.0, 1.5)
    spd = _ar1(rng, len(tt), dt, 4.0, 0.6)
    t = np.arange(n_fft / 2 / prf, dur - n_fft / prf, n_fft / 2 / prf)
    harm = np.arange(1, 5)
    x = np.empty((len(t), len(harm)))
    for k, n in enumerate(harm):
        own = _ar1(rng, len(tt), dt, 1.5, 0.3)
        x[:, k] = 10 * np.log10(cpi_average(tt, 10 ** ((fad + own + beta * n * spd) / 10), t, win, prf))
    x += rng.normal(0, 0.3, x.shape)
    ok = np.ones(x.shape, bool)
    m = np.ones(len(t), bool)
    u = cpi_average(tt, spd, t, win, prf)
    # the slope, with the fading made to follow the speed: unchanged
    assert abs(harmonic_speed_slope(x, ok, harm, u) / beta - 1) < 0.1
    assert abs(harmonic_speed_slope(x + 2.0 * u[:, None], ok, harm, u) / beta - 1) < 0.1

    def meas(f_log):
        return SimpleNamespace(
            t_s=t,
            range_m=np.full(len(t), 1500.0),
            harm=harm,
            f_log_hz=f_log,
            stft=SimpleNamespace(window=win),
            info={"prf_hz": prf},
        )

    seen = 10 * np.log10(cpi_average(tt, 10 ** (fad / 10), t, win, prf))
    ref = C.fit_gain_process(seen - seen.mean(), m, np.zeros(len(t)), t[1] - t[0], win, prf, drift=False)
    est = C.fading_estimate(meas(80.0 + u), x, ok, m)
    assert abs(est["speed_tilt_db"] / beta - 1) < 0.1
    assert abs(est["sigma_db"] / ref["sigma_db"] - 1) < 0.15, (est["sigma_db"], ref["sigma_db"])
    assert abs(est["timescale_s"] / ref["timescale_s"] - 1) < 0.2, (est["timescale_s"], ref["timescale_s"])
    blind = C.fading_estimate(meas(np.full(len(t), 80.0)), x, ok, m)
    assert blind["speed_tilt_db"] == 0.0
    assert blind["timescale_s"] < 0.75 * ref["timescale_s"], (blind["timescale_s"], ref["timescale_s"])


# ---------------------------------------------------------------- skipped flights


@pytest.fixture(scope="module")
def odd_flights():
    """Flights that cannot be diagnosed: (flight, field that names why, reason words)."""
    drone, _ = emulate_flight(FlightSpec("d_ok", "drone", drone_model="inspire2", duration_s=6.0, seed=2))
    bird, _ = emulate_flight(FlightSpec("bird1", "bird", bird_kind="single", duration_s=4.0, seed=1))
    empty = Flight(
        attrs={
            **{k: v for k, v in bird.attrs.items() if k not in ("flight_id", "target")},
            "flight_id": "empty1",
            "target": "none",
        },
        iq=bird.background_iq,
        track_time_s=bird.track_time_s,
        track_range_m=bird.track_range_m,
        track_radial_velocity_mps=bird.track_radial_velocity_mps,
    )
    mini, _ = emulate_flight(FlightSpec("mini1", "drone", drone_model="mini2", duration_s=4.0, seed=3))

    def variant(fid, **kw):
        return replace(drone, attrs={**drone.attrs, "flight_id": fid}, **kw)

    return {
        "bird": (bird, "attrs.target", "bird flight: no rotors"),
        "target-free": (empty, "attrs.target", "no rotors"),
        "mini": (mini, "attrs.blade_length_m", "rotor lines invisible"),
        "no log": (variant("nolog", motors_time_s=None, motors_rpm=None), "motors", "no motor log"),
        "all-zero log": (
            variant("zerolog", motors_rpm=np.zeros_like(drone.motors_rpm)),
            "motors/rpm",
            "zero everywhere",
        ),
        "rev/s as rpm": (
            variant("revs", motors_rpm=(drone.motors_rpm / 60).astype(np.float32)),
            "motors/rpm",
            "implausible",
        ),
        "log after the flight": (
            variant("late", motors_time_s=drone.motors_time_s + 100.0),
            "motors/time_s",
            "outside the flight",
        ),
        "too few pulses": (
            variant("short", iq=drone.iq[:30000], background_iq=drone.background_iq[:30000]),
            "iq",
            "too short",
        ),
    }


def test_diagnose_lists_every_flight_skipped_with_a_reason(tmp_path, odd_flights):
    stores = [write_flight(tmp_path / f"{f.flight_id}.zarr", f) for f, _, _ in odd_flights.values()]
    rep = diagnose(stores, tmp_path / "report.json", log=lambda m: None)
    assert rep["schema"] == REPORT_SCHEMA
    got = {e["flight_id"]: e for e in rep["flights"]}
    assert list(got) == [f.flight_id for f, _, _ in odd_flights.values()]
    for name, (f, field, words) in odd_flights.items():
        e = got[f.flight_id]
        assert e["cause"] == "skipped" and e["causes"] == [], (name, e)
        assert words in e["reason"], (name, e["reason"])
        if field.startswith("motors/"):
            assert field in e["reason"], (name, e["reason"])


@pytest.mark.parametrize(
    "name",
    ["bird", "target-free", "mini", "no log", "all-zero log", "rev/s as rpm", "log after the flight", "too few pulses"],
)
def test_diagnose_flight_raises_naming_the_field(odd_flights, name):
    flight, field, _ = odd_flights[name]
    with pytest.raises(InputError) as exc:
        diagnose_flight(flight, config={"figures": False})
    assert exc.value.field == field and f": {field}: " in str(exc.value)


def test_no_visible_rotor_lines_is_skipped():
    """Blades below the noise (decided from the data, with a log): skipped, not 'none'."""
    faint, _ = emulate_flight(
        FlightSpec(
            "faint", "drone", drone_model="inspire2", duration_s=12.0, snr_db=42.0, first_sideband_db=60.0, seed=7
        )
    )
    with pytest.raises(InputError, match="no rotor lines") as exc:
        diagnose_flight(faint, config={"figures": False})
    assert exc.value.reason.startswith("no visible rotor sidebands")


def test_weak_blades_make_sideband_causes_untestable_with_a_reason():
    """World v3's weak blades: a faint first sideband lets the flight be diagnosed (the
    rotor lines are seen) but not the sideband causes; the report says why instead of
    naming them or calling the flight clean of them."""
    for first_db in (28.0, 31.0):
        faint, _ = emulate_flight(
            FlightSpec(
                "weak",
                "drone",
                drone_model="inspire2",
                duration_s=24.0,
                snr_db=42.0,
                first_sideband_db=first_db,
                seed=11,
                effects={"sideband_asymmetry": {"asymmetry_db": 5.0}},
            )
        )
        try:
            entry = diagnose_flight(faint, config={"figures": False})
        except InputError as exc:  # too faint even to see the rotor lines: skipped
            assert exc.reason.startswith("no visible rotor sidebands")
            continue
        t = entry["evidence"]["tests"]["sideband_asymmetry"]
        assert "sideband_asymmetry" not in [c["cause"] for c in entry["causes"]]
        assert not t["testable"] and "usable sideband pairs" in t["reason"], t
        break
    else:
        pytest.fail("both flights were skipped: no case of a faint but visible rotor line")


# ---------------------------------------------------------------- the report file


@pytest.mark.slow
def test_report_file_follows_the_format_and_figure(tmp_path):
    spec = FlightSpec(
        "fmt01",
        "drone",
        drone_model="inspire2",
        duration_s=12.0,
        snr_db=40.0,
        effects={"sideband_asymmetry": {"asymmetry_db": 5.0}},
        seed=20261121,
    )
    flight, _ = emulate_flight(spec)
    store = write_flight(tmp_path / "fmt01.zarr", flight)
    bird, _ = emulate_flight(FlightSpec("b1", "bird", bird_kind="single", duration_s=4.0, seed=1))
    bstore = write_flight(tmp_path / "b1.zarr", bird)
    rep = diagnose([store, bstore], tmp_path / "report.json", figures_dir=tmp_path / "figs", log=lambda m: None)
    on_disk = json.loads((tmp_path / "report.json").read_text())
    assert on_disk == json.loads(json.dumps(rep))
    assert on_disk["schema"] == "diagnosis-report/2"
    assert on_disk["catalog"][0] == "none" and set(CATALOG) <= set(on_disk["catalog"])
    e, b = on_disk["flights"]
    assert b == {"flight_id": "b1", "cause": "skipped", "causes": [], "reason": "bird flight: no rotors"}
    assert set(e) >= {"flight_id", "cause", "causes"}
    assert e["cause"] == (e["causes"][0]["cause"] if e["causes"] else "none")
    assert e["cause"] == "sideband_asymmetry"
    assert isinstance(e["not_testable"], dict)
    for c in e["causes"]:
        if c["cause"] == "unexplained":  # no extension: the model with every named cause still misses
            assert c is e["causes"][-1] and set(c["params"]) == {"excess_db", "band_hz"}
            continue
        assert set(c) >= {"cause", "extension", "gain", "evidence"}
        assert c["cause"] in on_disk["catalog"] and c["extension"]["name"] == c["cause"]
        assert set(c["extension"]["params"]) == {p.name for p in CAUSES[c["cause"]].params}
        assert {"metric", "baseline", "extended", "held_out", "agrees_with_evalue"} <= set(c["gain"])
        # the gain and the e-value tell one story, or the entry says why not
        agrees = c["gain"]["extended"] < c["gain"]["baseline"]
        assert c["gain"]["agrees_with_evalue"] == agrees and (agrees or c["gain"]["why"])
    assert (tmp_path / "figs" / "fmt01.png").stat().st_size > 10_000
    assert not (tmp_path / "figs" / "b1.png").exists()


# ---------------------------------------------------------------- config


@pytest.mark.parametrize(
    "d, field, words",
    [
        ({"n_fft": "big"}, "diagnosis.n_fft", "an integer >= 64"),
        ({"n_fft": 32}, "diagnosis.n_fft", ">= 64"),
        ({"alpha": 2}, "diagnosis.alpha", "in (0, 1)"),
        ({"alpha": float("nan")}, "diagnosis.alpha", "finite"),
        ({"alpha": "0.01"}, "diagnosis.alpha", "a number"),
        ({"block_cpis": 0}, "diagnosis.block_cpis", ">= 1"),
        ({"block_cpis": 2.5}, "diagnosis.block_cpis", "an integer"),
        ({"figures": "yes"}, "diagnosis.figures", "true or false"),
        ({"seed": True}, "diagnosis.seed", "an integer"),
        ({"max_lag_s": 0.001}, "diagnosis.max_lag_s", ">= 0.01"),
        ({"margin_std_db": -1}, "diagnosis.margin_std_db", ">= 0"),
        ({"min_log_coverage": 0}, "diagnosis.min_log_coverage", "in (0, 1]"),
        ({"nfft": 4096}, "diagnosis.nfft", "unknown key"),
        # fields fixed since issue 35 are unknown keys that name the fixed field (issue 57)
        ({"lag_step_s": 0.02}, "diagnosis.lag_step_s", "microdoppler.diagnosis.DiagnosisConfig.lag_step_s"),
        ({"pn_line_guard_frac": 0.2}, "diagnosis.pn_line_guard_frac", "DiagnosisConfig.line_guard_frac"),
        ({"n_boot": 10}, "diagnosis.n_boot", "DiagnosisConfig.n_boot"),
        ({"margin_body_std_db": 2.0}, "diagnosis.margin_body_std_db", "the field margin_std_db"),
    ],
)
def test_config_rejects_bad_values_naming_the_field(d, field, words):
    with pytest.raises(ConfigError) as exc:
        DiagnosisConfig.from_dict(d, source="my.yaml")
    msg = str(exc.value)
    assert msg.startswith(f"my.yaml: {field}: ") and words in msg, msg
    assert exc.value.field == field


def test_the_fixed_settings_are_fields_but_no_config_keys():
    """The diagnosis's fixed settings (issue 57) are config=False fields: a config that
    sets one is an unknown key naming the field; their ranges hold on construction."""
    from dataclasses import fields

    from microdoppler.configfields import config_names

    keys = set(config_names(DiagnosisConfig))
    fixed = {f.name for f in fields(DiagnosisConfig)} - keys
    assert {"raised_floor_db", "lag_step_s", "n_boot", "line_false_alarm", "common_gain_corr"} <= fixed
    for name in sorted(fixed):
        with pytest.raises(ConfigError, match=f"no longer a setting: .*DiagnosisConfig.{name}"):
            DiagnosisConfig.from_dict({name: getattr(DiagnosisConfig(), name)})
        with pytest.raises(ConfigError, match="no longer a setting"):
            split_settings({name: getattr(DiagnosisConfig(), name)})
    assert DiagnosisConfig(lag_step_s=0.02).lag_step_s == 0.02
    with pytest.raises(ConfigError, match="min_pair_snr"):
        DiagnosisConfig(min_pair_snr=-1.0)


def test_config_direct_construction_and_split_settings():
    with pytest.raises(ConfigError, match="diagnosis.alpha"):
        DiagnosisConfig(alpha=2.0)
    cfg = DiagnosisConfig.from_dict({"n_fft": 2048, "alpha": 0.05, "margin_std_db": 3})
    assert cfg.n_fft == 2048 and cfg.alpha == 0.05
    assert cfg.margin_std_db == 3.0 and isinstance(cfg.margin_std_db, float)
    import yaml

    section = yaml.safe_load((REPO / "config" / "config.yaml").read_text())["diagnosis"]
    pipe, cfg = split_settings(section, source="config/config.yaml")
    assert pipe == {
        "sets": section["sets"],
        "population_sets": section["population_sets"],
        "min_fraction": section["min_fraction"],
        "flight_batches": section["flight_batches"],
    }
    assert cfg.alpha == section["alpha"] and cfg.block_cpis == section["block_cpis"]
    assert split_settings(None) == (
        {
            "sets": ["train", "validation", "test"],
            "population_sets": ["train"],
            "min_fraction": 0.25,
            "flight_batches": 2,
        },
        DiagnosisConfig(),
    )
    for bad, field in [
        ({"sets": "train"}, "diagnosis.sets"),
        ({"sets": ["training"]}, "diagnosis.sets[0]"),
        ({"sets": ["test"]}, "diagnosis.population_sets[0]"),
        ({"population_sets": ["val"]}, "diagnosis.population_sets[0]"),
        ({"min_fraction": 2}, "diagnosis.min_fraction"),
        ({"flight_batches": 0}, "diagnosis.flight_batches"),
        ({"flight_batches": 1.5}, "diagnosis.flight_batches"),
        ({"alpha": 0}, "diagnosis.alpha"),
        ({"min_frac": 0.1}, "diagnosis.min_frac"),
        ({"body_smooth_cpis": 9}, "diagnosis.body_smooth_cpis"),
    ]:
        with pytest.raises(ConfigError) as exc:
            split_settings(bad, source="c.yaml")
        assert str(exc.value).startswith(f"c.yaml: {field}: "), str(exc.value)


# ---------------------------------------------------------------- aggregate


def _entry2(fid, cause, params):
    return {
        "flight_id": fid,
        "cause": cause,
        "causes": [
            {
                "cause": cause,
                "extension": {"name": cause, "params": params},
                "gain": {"metric": "m", "baseline": 1.0, "extended": 0.5, "held_out": True},
                "evidence": {},
            }
        ],
    }


def test_aggregate_keeps_frequent_causes_with_median_params():
    fl = [_entry2(f"f{i}", "sideband_asymmetry", {"asymmetry_db": a}) for i, a in enumerate([3.0, 5.0, 4.0])]
    fl += [_entry2("f9", "motor_log_lag", {"lag_s": 0.5}), {"flight_id": "f8", "cause": "none", "causes": []}]
    fl += [{"flight_id": f"s{i}", "cause": "skipped", "causes": [], "reason": "no motor log"} for i in range(6)]
    rep = {"schema": REPORT_SCHEMA, "catalog": list(CATALOG), "flights": fl}
    ext = aggregate(rep, min_fraction=0.3)  # skipped flights are not in the denominator: 3/5 and 1/5
    assert ext.effects == {"sideband_asymmetry": {"asymmetry_db": 4.0}}
    assert ext.meta["n_flights"] == 5 and ext.meta["n_skipped"] == 6
    only = aggregate(rep, min_fraction=0.3, flight_ids={"f9", "f8"})
    assert set(only.effects) == {"motor_log_lag"}


def test_aggregate_reads_report_1():
    fl = [
        {
            "flight_id": f"f{i}",
            "cause": "sideband_asymmetry",
            "extension": {"name": "sideband_asymmetry", "params": {"asymmetry_db": a}},
        }
        for i, a in enumerate([3.0, 5.0, 4.0])
    ]
    fl += [{"flight_id": "f8", "cause": "none", "extension": None}]
    ext = aggregate({"catalog": list(CATALOG), "flights": fl}, min_fraction=0.5)
    assert ext.effects == {"sideband_asymmetry": {"asymmetry_db": 4.0}}


def test_cli_rejects_a_bad_store_in_one_line(tmp_path, capsys):
    from microdoppler.cli import main

    (tmp_path / "bad.zarr").mkdir()
    rc = main(["diagnose", str(tmp_path / "bad.zarr"), "--out", str(tmp_path / "r.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "bad.zarr" in err[0]
    assert not (tmp_path / "r.json").exists()
