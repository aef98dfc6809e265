"""Which declared fields a recording can test (:func:`microdoppler.rotors.plausibility.setup_testability`):
physics of the checks, on hand-made HERM combs (no generator of the project).

A rotor comb (two-blade rotors at 100 rev/s, 0.12 m blades, 3.3 GHz: tips at 75 m/s)
is drawn as lines every B f = 200 Hz about the body, 30 dB over white noise, out to a
chosen share of the declared tips' reach. The claims:

- a hovering target whose rotor speeds come from its own lines tests neither the PRF nor
  the blade count (both scale the lines, the speeds and the tips alike); a motor log
  from elsewhere tests both; a moving target's track tests the PRF and the carrier;
- the tips test the blade length (and, with lines past 2/3 of the reach, the blade
  count) only where the lines reach past half the tips' reach; and what the function
  calls testable is what the import's own check refuses: half the blade length is
  refused exactly where the lines reach past half the reach.
"""

from __future__ import annotations

import math
import re
from types import SimpleNamespace

import numpy as np
import pytest

from microdoppler.rotors.plausibility import rotor_problems, setup_testability, tip_reach_hz

PRF, CARRIER, L, REV_S, B = 8000.0, 3.3e9, 0.12, 100.0, 2
LAM = 299_792_458.0 / CARRIER


def comb(share: float, *, radial_mps: float = 0.0, seconds: float = 4.0, seed: int = 0, blade_length_m: float = L):
    """A drone recording whose lines reach ``share`` of the declared tips' reach (the
    body at the track's Doppler), declared with ``blade_length_m``."""
    rng = np.random.default_rng(seed)
    n = int(PRF * seconds)
    t = np.arange(n) / PRF
    body = -2 * radial_mps / LAM
    extent = share * tip_reach_hz(REV_S, L, CARRIER)
    iq = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / np.sqrt(2)
    iq = iq + 30 * np.exp(2j * np.pi * body * t)
    for k in range(1, int(extent // (B * REV_S)) + 1):
        for side in (1, -1):
            iq += 10 * np.exp(2j * np.pi * ((body + side * k * B * REV_S) * t + rng.uniform()))
    attrs = {"target": "drone", "prf_hz": PRF, "carrier_hz": CARRIER, "blade_length_m": blade_length_m, "n_blades": B}
    track_t = np.linspace(0.0, seconds, 20)
    return SimpleNamespace(
        attrs=attrs, iq=iq, track_time_s=track_t, track_radial_velocity_mps=np.full(20, radial_mps)
    ), extent


def test_a_hovering_comb_read_from_its_own_lines_tests_no_field():
    flight, extent = comb(0.3)
    out = setup_testability(flight, REV_S, log_independent=False)
    assert set(out) == {"prf_hz", "carrier_hz", "n_blades", "blade_length_m"}, out
    assert "scales the lines, the speeds and the tips' Doppler alike" in out["prf_hz"]
    assert "2 and 3 blades explain them alike" in out["n_blades"]
    # the reason quotes the lines' extent (the last line's offset, within its main lobe)
    # and its share of the tips' reach
    said = float(re.search(r"end at ±(\d+) Hz", out["blade_length_m"]).group(1))
    last = (extent // (B * REV_S)) * B * REV_S
    share = float(re.search(r"(\d+)% of the reach", out["blade_length_m"]).group(1)) / 100
    assert last <= said <= last + 50 and abs(share - said / tip_reach_hz(REV_S, L, CARRIER)) < 0.01


def test_a_motor_log_from_elsewhere_tests_the_prf_and_the_blade_count():
    flight, _ = comb(0.3)
    assert set(setup_testability(flight, REV_S, log_independent=True)) == {"carrier_hz", "blade_length_m"}


def test_a_moving_targets_track_tests_the_prf_and_the_carrier():
    """10 m/s away at 3.3 GHz: the body at -220 Hz; half of it (a factor 2 on the
    frequency axis) is well beyond the check's tolerance."""
    flight, _ = comb(0.3, radial_mps=10.0)
    assert set(setup_testability(flight, REV_S, log_independent=False)) == {"n_blades", "blade_length_m"}


def test_lines_that_reach_the_tips_test_the_blades():
    flight, _ = comb(0.8)
    assert set(setup_testability(flight, REV_S, log_independent=False)) == {"prf_hz"}


@pytest.mark.parametrize("share", [0.3, 0.45, 0.6, 0.8])
def test_what_is_called_testable_is_what_the_import_refuses(share):
    """Declared with blades half as long, the import's check (:func:`rotor_problems` at
    the same rate) refuses the set-up exactly where the true declaration calls the blade
    length testable (lines past half the reach), and says nothing otherwise."""
    flight, _ = comb(share)
    testable = "blade_length_m" not in setup_testability(flight, REV_S, log_independent=True)
    half, _ = comb(share, blade_length_m=L / 2)
    refused = rotor_problems(half, [REV_S], source="the log")
    assert testable == bool(refused), (share, refused)
    if refused:
        assert "blade_length_m" in refused[0][0]


def test_no_rate_or_no_lines_tests_nothing_by_the_tips():
    flight, _ = comb(0.8)
    assert "blade_length_m" in setup_testability(flight, None, log_independent=True)
    bird = SimpleNamespace(**{**vars(flight), "attrs": {**flight.attrs, "target": "bird"}})
    assert setup_testability(bird, REV_S, log_independent=False) == {}
    assert math.isclose(tip_reach_hz(REV_S, L, CARRIER) / tip_reach_hz(REV_S / 2, L, CARRIER), 2.0)


def test_an_ambiguous_radar_order_is_named_with_its_rates():
    """Rotor speeds the radar's order check marked ambiguous: the diagnosis took one of
    the rates the lines allow, and says which others it could have taken."""
    flight, _ = comb(0.8)
    order = {"ambiguous": True, "chosen_rev_s": REV_S}
    flight.attrs.update(
        motors_source="radar", motors_radar={"rotor_order": order, "rotor_order_alternatives_rev_s": [50.0, 33.3]}
    )
    out = setup_testability(flight, REV_S, log_independent=False)
    assert "reads 100.0 rev/s or 50.0, 33.3 rev/s" in out["rotor_order"], out
    order["ambiguous"] = False
    assert "rotor_order" not in setup_testability(flight, REV_S, log_independent=False)
    order["ambiguous"] = True
    flight.attrs["motors_source"] = "log"
    assert "rotor_order" not in setup_testability(flight, REV_S, log_independent=True)


def test_enough_cpis_but_nothing_testable_says_why_each_test_declined():
    """A flight whose CPIs suffice but whose every test declined is skipped with each
    test's reason, not with "too few usable CPIs" (any56207 of eval_orders read "has 17
    of 22 CPIs usable ... expected >= 16"); too few CPIs still reads as before."""
    from microdoppler.diagnosis import DiagnosisConfig
    from microdoppler.diagnosis.hypotheses import check_testable
    from microdoppler.diagnosis.measure import Undiagnosable

    cfg = DiagnosisConfig()
    valid = np.zeros(22, bool)
    valid[: 2 * cfg.block_cpis + 1] = True
    M = SimpleNamespace(flight_id="f", valid=valid, t_s=np.arange(22.0))
    tests = {
        "motor_log_lag": SimpleNamespace(testable=False, evidence={"reason": "log from the radar"}),
        "phase_noise": SimpleNamespace(testable=False, evidence={"reason": "body in the clutter notch"}),
    }
    with pytest.raises(Undiagnosable) as e:
        check_testable(M, tests, cfg)
    assert e.value.reason.startswith("no cause testable") and "too few" not in e.value.reason
    assert (
        "motor_log_lag: log from the radar" in e.value.reason and "phase_noise: body in the clutter" in e.value.reason
    )
    M.valid = valid & (np.arange(22) < 2 * cfg.block_cpis - 1)
    with pytest.raises(Undiagnosable) as e:
        check_testable(M, tests, cfg)
    assert e.value.reason.startswith("too few usable CPIs")
