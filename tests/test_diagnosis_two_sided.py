"""The goodness of fit reads both ways (issue 56): a model that puts lines where the
recording has none is ``unexplained``, not ``none``.

A recording of the any-radar generator (:mod:`microdoppler.examples`, which shares no
code with the synthesis: segment-tapered blades, 6 rotors of 3 blades at 5.8 GHz,
flying) is diagnosed with its true rotor speeds, once with its true set-up and once
with the blade length declared twice too long: the thin-wire model's lines then reach
twice as far in Doppler, beyond the recording's tips, where the recording has none.
Before the two-sided check this read ``none`` (the band test reads only the harmonics
the calibration used, all inside both extents).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from any_radar import draw_case, make_recording
from microdoppler.diagnosis import diagnose_flight
from microdoppler.diagnosis.explain import SUSPECT_FIELDS, missing_reason
from microdoppler.io.motorlog import MotorLog

_RUNS: dict = {}


def _entry(blade_factor: float) -> dict:
    """The diagnosis of the recording with its blade length declared ``blade_factor``
    times the true one (computed once per session)."""
    if blade_factor not in _RUNS:
        if "rec" not in _RUNS:
            case = draw_case(41019, duration_s=12.0)
            _RUNS["rec"] = make_recording(case)
        flight, truth = _RUNS["rec"]
        log = MotorLog(np.asarray(truth["time_s"], float), np.asarray(truth["rev_s"], float) * 60.0, "truth")
        attrs = {**flight.attrs, "blade_length_m": flight.attrs["blade_length_m"] * blade_factor}
        _RUNS[blade_factor] = diagnose_flight(replace(flight, attrs=attrs), motor_log=log, config={"figures": False})
    return _RUNS[blade_factor]


def test_true_set_up_reads_none_both_ways():
    e = _entry(1.0)
    g = e["evidence"]["goodness_of_fit"]
    assert g["missing"] == [] and g["missing_reason"] == "", g["missing"]
    assert g["lines_read"] > 8
    assert "unexplained" not in [c["cause"] for c in e["causes"]], e["causes"]


def test_model_lines_where_the_recording_has_none_read_unexplained():
    e = _entry(2.0)
    g = e["evidence"]["goodness_of_fit"]
    assert g["excess"] is True
    assert g["missing"] and all(m["direction"] == "model_only" for m in g["missing"]), g["missing"]
    # beyond the recording's tips: 2 v_tip / lambda
    case = draw_case(41019, duration_s=12.0)
    tips_hz = 2 * case.tip_speed_mps / case.wavelength_m
    assert all(min(abs(x) for x in m["band_hz"]) > 0.9 * tips_hz for m in g["missing"]), (tips_hz, g["missing"])
    u = next(c for c in e["causes"] if c["cause"] == "unexplained")
    assert e["cause"] != "none"
    assert "the model puts lines where the recording has none" in u["reason"]
    assert "blade_length_m" in u["reason"] and "carrier_hz" in u["reason"]


@pytest.mark.parametrize(
    "directions, text",
    [
        ([], ""),
        (["model_only"], "the model puts lines where the recording has none: check " + SUSPECT_FIELDS),
        (["recording_only"], "the recording holds lines the model lacks: check " + SUSPECT_FIELDS),
    ],
)
def test_missing_reason_names_the_direction_and_the_fields(directions, text):
    assert missing_reason([{"direction": d} for d in directions]) == text
