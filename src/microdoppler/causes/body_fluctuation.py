"""``body_fluctuation``: the body return's power fluctuating from CPI to CPI (RCS
scintillation).

- catalog: ``body_std_db`` [dB], ``timescale_s`` [s] (default :data:`BODY_TIMESCALE_S`);
- test (:func:`test_body`): the body power [dB] per CPI, detrended; baseline the
  measurement noise, extension adds a fitted variance; size and correlation time
  from the short-window body power (:func:`body_estimate`); needs the body line;
- twins: ``body_hook`` multiplies the body amplitude by 10^(y(t)/20), y OU in dB;
- emulator: the body amplitude is multiplied by such a gain (drawn after the blade gains).
"""

from __future__ import annotations

import numpy as np

from ..synthesis.processes import GainHook, SlowGain
from .base import CauseSpec, Param, draw_band_panel
from .heldout import CauseTest, _detrend, _power_fluct_test, fit_gain_process
from .measure import DB

NAME = "body_fluctuation"
#: sub-seed of the twins' body process (independent streams from one seed)
STREAM = 2
#: default correlation time of the body fluctuation [s] when ``timescale_s`` is not given
BODY_TIMESCALE_S = 0.3
#: correlation time of the emulator's knob [s] when not given (catalog: ~0.3 s)
BODY_FLUCTUATION_TAU_S = 0.3


def body_estimate(M) -> dict:
    """Size [dB] and 1/e correlation time [s] of the body power's fluctuation, from the
    short-window body power series (:func:`.measure.body_power_fine`), detrended
    linearly in time and log range (:func:`fit_gain_process`)."""
    F = M.body_fine
    v = F["valid"]
    y = np.zeros(len(v))
    if v.sum() >= 20:
        y[v] = _detrend(F["y_db"][v], F["t_s"][v], F["range_m"][v])
    # no drift term: tried on emulated (aspect 1 dB, 4 s) and independent flights, a
    # free drift took part of any fluctuation slower than ~0.5 s (sizes came out low)
    return fit_gain_process(y, v, F["noise_var_db2"], F["hop_s"], F["window"], M.info["prf_hz"], drift=False)


def test_body(M, cfg, fold) -> CauseTest:
    m = M.valid & (M.body_pow > 0)
    y = np.where(m, DB * np.log(np.maximum(M.body_pow, 1e-30)), 0.0)
    res, s2 = _power_fluct_test(NAME, y, M.body_sd_db, m, M, cfg, fold, smooth=cfg.body_smooth_cpis)
    res.statistic = "body power [dB], detrended"
    if s2 is not None:
        est = (
            body_estimate(M)
            if s2 > 0
            else {"sigma_db": 0.0, "timescale_s": float("nan"), "lags_s": [], "variogram_db2": []}
        )
        sd = float(est["sigma_db"])
        tau = float(est["timescale_s"]) if sd > 0 and np.isfinite(est["timescale_s"]) else float("nan")
        res.params = {"body_std_db": sd, "timescale_s": tau}
        res.effect = sd
        res.relevant = sd >= cfg.margin_std_db
        res.evidence.update(
            {
                "body_std_db": round(sd, 2),
                "timescale_s": round(tau, 3),
                "variogram_lags_s": [round(x, 3) for x in est["lags_s"]],
                "variogram_db2": [round(x, 3) for x in est["variogram_db2"]],
            }
        )
    return res


class BodyFluctuation(CauseSpec):
    name = NAME
    meaning = "the body return's power fluctuates from CPI to CPI (RCS scintillation)"
    params = (
        Param("body_std_db", "dB", "standard deviation of the body power gain in dB", ">= 3"),
        Param(
            "timescale_s", "s", "1/e correlation time of the body power gain (default 0.3 s when not given)", "0.05-3 s"
        ),
    )
    observations = ("body_pow", "body_sd_db", "body_fine", "valid", "t_s", "range_m", "info")
    line = "body"
    margin_field = "margin_std_db"
    defaults = {"timescale_s": BODY_TIMESCALE_S}  # files written before timescale_s existed
    bounds = (("body_std_db", ">= 0"), ("timescale_s", "> 0"))
    world_defaults = {"timescale_s": BODY_FLUCTUATION_TAU_S}

    def test(self, M, cfg, fold, given=frozenset()):
        return test_body(M, cfg, fold)

    def model_extension(self, p, *, duration_s, seed):
        rng = np.random.default_rng([int(seed), STREAM])
        return {"body_hook": GainHook(duration_s, p["body_std_db"], p["timescale_s"], rng)}

    def world_check(self, full):
        if not (full["body_std_db"] >= 0 and full["timescale_s"] > 0):
            raise ValueError(
                f"{NAME}: body_std_db={full['body_std_db']} must be >= 0 and timescale_s={full['timescale_s']} > 0"
            )

    def world_body_gain(self, p, duration_s, rng):
        return SlowGain(duration_s, p["body_std_db"], p["timescale_s"], rng)

    def draw_panel(self, ax, test):
        draw_band_panel(ax, test)

    def gof_body_half(self, band_hz):
        # the fluctuation's skirt scales with the body line: its neighbours too
        return 1.5 * band_hz


CAUSE = BodyFluctuation()
