"""``motor_speed_scale``: the logged speeds off by a constant factor.

- catalog: ``scale`` [1], true speed / logged speed;
- test (:func:`.motor_log.test_log`): y = ln(measured / logged HERM spacing) per CPI;
  baseline N(0, s^2), extension N(ln scale, s^2), contaminated by 5 % outliers; with
  ``motor_log_lag`` named, the lag is in both models (``test_partners``); not
  testable on a log estimated from the radar;
- twins: true speed = scale * logged speed;
- emulator: logged speed = true speed / scale.
"""

from __future__ import annotations

import numpy as np

from .base import CauseSpec, Param
from .motor_log import FROM_RADAR, test_log

NAME = "motor_speed_scale"


class MotorSpeedScale(CauseSpec):
    name = NAME
    meaning = "the logged speeds are off by a constant factor"
    params = (
        Param("scale", "1", "true speed / logged speed (HERM spacing / the log's prediction)", "|scale - 1| >= 0.05"),
    )
    observations = ("dil", "dil_ok", "valid", "lag_s", "lag_curves", "f_log_hz", "t_s")
    line = "rotor"
    test_partners = frozenset({"motor_log_lag"})
    margin_field = "margin_scale"
    bounds = (("scale", "> 0"),)

    def test(self, M, cfg, fold, given=frozenset()):
        return test_log(M, cfg, fold, frozenset(given))[1]

    def untestable(self, M):
        return FROM_RADAR if M.log_from_radar else None

    def transform_log(self, p, t, rpm):
        return t, (rpm.astype(np.float64) * p["scale"]).astype(np.float32)

    def world_check(self, full):
        if not full["scale"] > 0:
            raise ValueError(f"{NAME}: scale={full['scale']} must be > 0")

    def world_log(self, p):
        return {"scale": p["scale"]}


CAUSE = MotorSpeedScale()
