"""A campaign of one's own: every stage runs on flights from any radar, or says why
not in one line (docs/campaign.md).

- the diagnosis's CPI and minimum duration follow seconds: a 20-s recording at a
  2 kHz PRF is long enough, a shorter one is skipped with the minimum in seconds;
- a campaign without birds: the classifier refuses one class in one line;
- a fidelity table that cannot be formed names the flights and the reason.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from any_radar import draw_case, make_recording
from microdoppler.diagnosis import DiagnosisConfig
from microdoppler.diagnosis.measure import Undiagnosable, check_diagnosable
from microdoppler.io.motorlog import MotorLog


def _recording(duration_s: float, prf_hz: float = 2000.0):
    """A flying drone of tests/any_radar.py at ``prf_hz`` (3.3 GHz, 0.15 m blades) and
    its true rotor speeds as a motor log."""
    case = draw_case(5, duration_s=duration_s, prf_hz=prf_hz, carrier_hz=3.3e9, blade_length_m=0.15,
                     setup="flying", radial_speed_mps=4.0)
    flight, truth = make_recording(case)
    log = MotorLog(np.asarray(truth["time_s"], float), (np.asarray(truth["rev_s"]) * 60.0).astype(np.float32),
                   "truth")
    return flight, log


def test_diagnosis_cpi_follows_seconds():
    cfg = DiagnosisConfig()
    assert cfg.cpi_pulses(7300.0) == 4096  # the paper's radar: today's CPI
    assert cfg.cpi_pulses(2000.0) == 1024
    assert DiagnosisConfig(n_fft=4096).cpi_pulses(2000.0) == 4096


def test_twenty_second_flight_at_2khz_is_not_too_short():
    flight, log = _recording(20.0)
    assert len(flight.iq) == 40000
    check_diagnosable(flight, log, DiagnosisConfig())  # no Undiagnosable
    # the same flight with the CPI fixed at 4096 pulses (2 s) was skipped
    with pytest.raises(Undiagnosable) as exc:
        check_diagnosable(flight, log, DiagnosisConfig(n_fft=4096))
    assert exc.value.reason.startswith("flight too short: iq: has 40000 pulses at 2000 Hz = 20 s")


@pytest.mark.parametrize("duration_s, min_duration_s, expect", [
    (4.0, 0.0, "expected >= 5.38 s: 20 CPIs of 0.512 s"),
    (8.0, 10.0, "expected >= 10 s: 20 CPIs of 0.512 s"),
])
def test_too_short_flight_says_the_minimum_in_seconds(duration_s, min_duration_s, expect):
    flight, log = _recording(duration_s)
    with pytest.raises(Undiagnosable) as exc:
        check_diagnosable(flight, log, DiagnosisConfig(min_duration_s=min_duration_s))
    reason = exc.value.reason
    assert "\n" not in reason
    assert reason.startswith(f"flight too short: iq: has {len(flight.iq)} pulses at 2000 Hz = {duration_s:g} s")
    assert expect in reason, reason
    assert exc.value.field == "iq"
