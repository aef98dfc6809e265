"""``motor_log_lag``: the motor log shifted in time against the radar.

- catalog: ``lag_s`` [s], t_logged - t_true (positive = log late);
- test (:func:`.motor_log.test_log`): y = ln(measured / logged HERM spacing) per CPI;
  baseline N(0, s^2), extension N(ln f(t + lag) / f(t), s^2), contaminated by 5 %
  outliers; with ``motor_speed_scale`` named, the scale is in both models
  (``test_partners``); not testable on a log estimated from the radar;
- twins: the corrected log is the logged one with its times moved by -lag_s;
- emulator: a log row stamped t reports the true speed at t - lag_s.
"""

from __future__ import annotations

from .base import CauseSpec, Param
from .motor_log import FROM_RADAR, test_log

NAME = "motor_log_lag"


class MotorLogLag(CauseSpec):
    name = NAME
    meaning = "the motor log is shifted in time against the radar"
    params = (
        Param(
            "lag_s",
            "s",
            "t_logged - t_true: a row stamped t reports the speed at t - lag_s; positive = log late",
            "|lag_s| >= 0.3",
        ),
    )
    observations = ("dil", "dil_ok", "valid", "lag_s", "lag_curves", "f_log_hz", "t_s")
    line = "rotor"
    test_partners = frozenset({"motor_speed_scale"})
    margin_field = "margin_lag_s"

    def test(self, M, cfg, fold, given=frozenset()):
        return test_log(M, cfg, fold, frozenset(given))[0]

    def untestable(self, M):
        return FROM_RADAR if M.log_from_radar else None

    def transform_log(self, p, t, rpm):
        return t - p["lag_s"], rpm

    def world_check(self, full):
        if not abs(full["lag_s"]) < 10:
            raise ValueError(f"{NAME}: lag_s={full['lag_s']} must be within +-10 s")

    def world_log(self, p):
        return {"lag_s": p["lag_s"]}


CAUSE = MotorLogLag()
