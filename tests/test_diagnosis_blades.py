"""Unequal blades, "unexplained" and hovering targets in the diagnosis (issues 33, 34).

Flights come from :mod:`independent_generator` (no code shared with the emulator, the
synthesis, the extensions or the processes; its own radars and constants). Effect
sizes are drawn from a seed the diagnosis never sees.
"""

from __future__ import annotations

import numpy as np
import pytest

from independent_generator import GenCase, make_flight
from microdoppler.diagnosis import diagnose_flight
from microdoppler.diagnosis.hypotheses import imbalance_from_ratio
from microdoppler.causes.extensions import ExtensionSet

#: the issue's tolerance on imbalance_db [dB]
IMBALANCE_TOL_DB = 1.5
_DRAW = np.random.default_rng(20261126)
#: two imbalances drawn in the issue's range 3-10 dB (the diagnosis never sees the seed)
IMBALANCES_DB = [float(x) for x in _DRAW.uniform(3.0, 10.0, 2)]


def _diagnose(name, seed, radar, effects=None, oddities=None, **kw):
    flight, truth = make_flight(
        GenCase(name, seed, radar, effects or {}, duration_s=20.0, oddities=oddities or {}, **kw)
    )
    return diagnose_flight(flight, config={"figures": False}), truth


def _named(entry):
    return [c["cause"] for c in entry["causes"]]


def test_imbalance_ratio_inverts_the_blade_sum():
    """r = ((1 - a) / (B - 1 + a))^2 for one blade of amplitude a: the inverse gives a back."""
    for B in (2, 3):
        for a in (0.9, 0.5, 0.316, 0.1):
            r = ((1 - a) / (B - 1 + a)) ** 2
            assert imbalance_from_ratio(r, B) == pytest.approx(-20 * np.log10(a), abs=1e-9)
    assert imbalance_from_ratio(0.0, 2) == 0.0
    assert np.isnan(imbalance_from_ratio(1.5, 2))  # more than one blade can make


def test_imbalance_extension_keeps_the_blade_passing_level():
    """The extension's amplitudes sum to the blade count (the blade-passing lines keep
    their calibrated level) and put the non-multiple lines r below them."""
    for B, imb in ((2, 6.0), (3, 4.0)):
        amps = ExtensionSet({"blade_imbalance": {"imbalance_db": imb}}).blade_amplitudes(B)
        assert amps.sum() == pytest.approx(B)
        a = amps[0] / amps[1]
        assert -20 * np.log10(a) == pytest.approx(imb)
        k = np.arange(1, 3 * B + 1)
        phases = np.exp(2j * np.pi * np.outer(k, np.arange(B)) / B)
        lines = np.abs(phases @ amps) ** 2
        r = lines[k % B != 0].mean() / lines[k % B == 0].mean()
        assert imbalance_from_ratio(r, B) == pytest.approx(imb, abs=1e-6)
    assert ExtensionSet({}).blade_amplitudes(2) is None


@pytest.mark.slow
@pytest.mark.parametrize("radar,seed,imb", [("gen_l", 401, IMBALANCES_DB[0]), ("gen_s", 402, IMBALANCES_DB[1])])
def test_imbalance_named_and_measured(radar, seed, imb):
    entry, _ = _diagnose("imb", seed, radar, {"blade_imbalance": {"imbalance_db": imb}})
    assert "blade_imbalance" in _named(entry), entry["causes"]
    fit = next(c for c in entry["causes"] if c["cause"] == "blade_imbalance")["extension"]["params"]["imbalance_db"]
    assert abs(fit - imb) <= IMBALANCE_TOL_DB


@pytest.mark.slow
def test_imbalance_not_fooled_by_sideband_causes():
    """An asymmetric or fading sideband set is not an imbalance."""
    for seed, eff in (
        (403, {"sideband_asymmetry": {"asymmetry_db": 4.5}}),
        (404, {"sideband_fading": {"fading_std_db": 4.0, "timescale_s": 1.5}}),
    ):
        entry, _ = _diagnose("bal", seed, "gen_s", eff)
        assert "blade_imbalance" not in _named(entry), entry["causes"]
        assert entry["evidence"]["tests"]["blade_imbalance"]["params"]["imbalance_db"] < 1.5


@pytest.mark.slow
@pytest.mark.parametrize(
    "oddity", [{"second_scatterer": {"offset_hz": 41.0, "level_db": -12.0, "wander_hz": 2.0}}, {"true_n_blades": 3}]
)
def test_out_of_catalog_is_unexplained_never_none(oddity):
    entry, _ = _diagnose("odd", 405, "gen_l", oddities=oddity)
    assert entry["cause"] != "none"
    assert "unexplained" in _named(entry), entry["causes"]
    un = next(c for c in entry["causes"] if c["cause"] == "unexplained")
    assert abs(un["params"]["excess_db"]) >= 4.0
    lo, hi = un["params"]["band_hz"]
    assert lo < hi


@pytest.mark.slow
def test_clean_flight_fits_and_lists_what_it_could_not_test():
    entry, _ = _diagnose("clean", 406, "gen_l")
    assert entry["cause"] == "none", entry["causes"]
    assert entry["evidence"]["goodness_of_fit"]["excess"] is False
    assert isinstance(entry["not_testable"], dict)


@pytest.mark.slow
def test_hovering_target_is_diagnosed_on_its_rotor_lines():
    """Body at 0 Hz (hovering, on a stand): not skipped; the body-line tests report
    not testable with the reason, the sideband tests run."""
    entry, _ = _diagnose("hover", 407, "gen_s", {"sideband_asymmetry": {"asymmetry_db": -4.0}}, speed_mps=0.0)
    assert entry["cause"] != "skipped"
    assert "sideband_asymmetry" in _named(entry)
    for cause in ("body_fluctuation", "phase_noise"):
        assert "clutter notch" in entry["not_testable"][cause]
    asym = next(c for c in entry["causes"] if c["cause"] == "sideband_asymmetry")
    assert asym["extension"]["params"]["asymmetry_db"] == pytest.approx(-4.0, abs=1.0)


#: a shallow range-cell straddle (3.5-4.5 dB deep: a std of ~1.2-1.6 dB, between the
#: two margins), drawn from a seed the diagnosis never sees
_STRADDLE_DRAW = np.random.default_rng(34_2028)
STRADDLE = {"depth_db": float(_STRADDLE_DRAW.uniform(3.5, 4.5)), "period_s": float(_STRADDLE_DRAW.uniform(8.0, 12.0))}


@pytest.mark.slow
def test_shallow_range_straddle_is_unexplained():
    """A slow gain on the whole target (body and blades together) is no catalog cause:
    ``unexplained`` from a 1 dB std (``margin_common_gain_db``); with the fading's 2 dB
    margin this one came out ``none`` (checked by setting it back)."""
    flight, _ = make_flight(
        GenCase("straddle", 407, "gen_l", {}, duration_s=30.0, oddities={"range_straddle": STRADDLE})
    )
    entry = diagnose_flight(flight, config={"figures": False})
    assert _named(entry) == ["unexplained"], (entry["causes"], STRADDLE)
    un = entry["causes"][-1]
    assert un["evidence"].get("kind") == "a power fluctuation common to the body and the blades", un
    assert un["evidence"]["body_correlation"] > 0.7


def test_imbalance_interval_is_one_sided_where_one_blade_dominates():
    """The interval of imbalance_db from the non-multiple/blade-passing ratio: a
    ratio within noise of a lone blade's (0 dB for two blades) bounds the imbalance
    from below only; a ratio of a 10 dB imbalance gives a two-sided interval around
    10 dB; no non-multiple power bounds it from above only."""
    from microdoppler.causes.blade_imbalance import imbalance_from_ratio, imbalance_interval

    rng = np.random.default_rng(3)
    idx = np.repeat(np.arange(40), 6)  # 40 CPIs, 6 observations each
    lone = imbalance_interval(1.0 + 0.05 * rng.standard_normal(idx.size), idx, 2, 8, seed=1)
    assert lone["bound"] == "lower" and lone["high"] is None and lone["low"] > 20, lone
    assert "one blade dominates" in lone["meaning"]
    a = 10 ** (-10 / 20)
    r = ((1 - a) / (1 + a)) ** 2
    assert imbalance_from_ratio(r, 2) == pytest.approx(10.0)
    two = imbalance_interval(r * (1 + 0.1 * rng.standard_normal(idx.size)), idx, 2, 8, seed=1)
    assert two["bound"] == "two-sided" and two["low"] < 10.0 < two["high"] and two["high"] - two["low"] < 3, two
    none = imbalance_interval(0.002 * rng.standard_normal(idx.size), idx, 2, 8, seed=1)
    assert none["bound"] == "upper" and none["low"] == 0.0, none
    # the same seed gives the same interval
    assert imbalance_interval(r * np.ones(idx.size), idx, 2, 8, seed=1) == imbalance_interval(
        r * np.ones(idx.size), idx, 2, 8, seed=1
    )
