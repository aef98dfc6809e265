"""The motor-log test shared by ``motor_log_lag`` and ``motor_speed_scale``
(:func:`test_log`): both read y = ln(measured / logged HERM spacing) per CPI, and
each is in the other's models once named. Not a cause module itself."""

from __future__ import annotations

import numpy as np

from .heldout import CauseTest, _crossfit, _gauss_ll

#: why a log estimated from the recording's own lines tests neither
FROM_RADAR = (
    "motors_source is radar: the motor log was estimated from this recording's HERM lines, so lag "
    "and scale are not testable"
)


def test_log(M, cfg, fold, given: frozenset = frozenset()) -> tuple[CauseTest, CauseTest]:
    """Lag and scale tests on y = ln(measured / logged HERM spacing) per CPI.

    ``given``: causes already named. The other one of the pair, when named, is in
    both models of each test, fitted on the training fold like the candidate:
    lag given scale compares N(mu, s^2) with N(G_lag + mu, s^2); scale given lag
    compares N(G_lag, s^2) with N(G_lag + ln scale, s^2). So one effect cannot be
    named twice (a lag during a speed ramp looks like a scale over that ramp)."""
    m = M.dil_ok & M.valid
    lag_res = CauseTest("motor_log_lag", statistic="ln(measured / logged HERM spacing)")
    sc_res = CauseTest("motor_speed_scale", statistic="ln(measured / logged HERM spacing)")
    if m.sum() < 2 * cfg.block_cpis:
        lag_res.testable = sc_res.testable = False
        return lag_res, sc_res
    y = np.log(M.dil[m])
    f = fold[m]
    lags = M.lag_s
    G = M.lag_curves[:, m]
    with_scale = "motor_speed_scale" in given
    with_lag = "motor_log_lag" in given
    out = cfg.log_outlier_frac

    def fit_joint(sel, use_lag: bool, use_scale: bool):
        """(lag index or None, mu, residual variance) fitted on ``sel``."""
        ys = y[sel]
        if not use_lag:
            mu = float(ys.mean()) if use_scale else 0.0
            return None, mu, float(np.mean((ys - mu) ** 2)) + 1e-10
        Gs = G[:, sel]
        mus = (ys[None, :] - Gs).mean(1) if use_scale else np.zeros(len(lags))
        sse = ((ys[None, :] - Gs - mus[:, None]) ** 2).sum(1)
        j = int(np.argmin(sse))
        return j, float(mus[j]), float(sse[j] / sel.sum()) + 1e-10

    def mean_of(th, sel):
        j, mu, _ = th
        return (G[j, sel] if j is not None else 0.0) + mu

    def crossfit(base_flags, ext_flags, res):
        # both models are contaminated normals: a fraction cfg.log_outlier_frac of the CPIs
        # may be outliers of the spacing match (speed steps, a line lost for a CPI),
        # N(0, 10 x the training fold's mean square); without it, a fold fitted on
        # smooth CPIs scores the other fold's few outliers at thousands of sigma
        def fit(sel):
            wide = 10.0 * float(np.mean(y[sel] ** 2)) + 1e-10
            return fit_joint(sel, *base_flags), fit_joint(sel, *ext_flags), wide

        def ll(x, mu, var, wide):
            return np.logaddexp(np.log1p(-out) + _gauss_ll(x, mu, var), np.log(out) + _gauss_ll(x, 0.0, wide))

        def score(th, sel):
            tb, te, wide = th
            return ll(y[sel], mean_of(tb, sel), tb[2], wide), ll(y[sel], mean_of(te, sel), te[2], wide)

        _crossfit(f, fit, score, res)

    crossfit((False, with_scale), (True, with_scale), lag_res)
    crossfit((with_lag, False), (with_lag, True), sc_res)
    # parameters on the whole flight: the lag with the scale in the model when the
    # scale is named (and vice versa), else alone
    allm = np.ones(len(y), bool)
    j, mu_l, _ = fit_joint(allm, True, with_scale)
    Gm = G[:, :]
    mus = (y[None, :] - Gm).mean(1) if with_scale else np.zeros(len(lags))
    sse = ((y[None, :] - Gm - mus[:, None]) ** 2).sum(1)
    lag = float(lags[j])
    if 0 < j < len(lags) - 1:  # parabolic refinement of the lag
        a, b, c = sse[j - 1], sse[j], sse[j + 1]
        if a - 2 * b + c > 0:
            lag += float(np.clip(0.5 * (a - c) / (a - 2 * b + c), -0.5, 0.5)) * cfg.lag_step_s
    if with_lag:
        jl, _, _ = fit_joint(allm, True, True)
        scale = float(np.exp(np.median(y - G[jl])))
    else:
        jl = None
        scale = float(np.exp(np.median(y)))
    lag_res.params = {"lag_s": lag}
    lag_res.effect = abs(lag)
    lag_res.relevant = abs(lag) >= cfg.margin_lag_s
    sc_res.params = {"scale": scale}
    sc_res.effect = abs(scale - 1)
    sc_res.relevant = abs(scale - 1) >= cfg.margin_scale
    spd = M.f_log_hz[m]
    ev = {
        "line_spacing_ratio": round(float(np.exp(np.median(y))), 4),
        "fitted_lag_s": round(lag, 3),
        "log_speed_range_hz": round(float(spd.max() - spd.min()), 2),
        "spacing_ratio_std": round(float(np.std(np.exp(y))), 4),
    }
    lag_res.evidence = {**ev, "given": sorted(given & {"motor_speed_scale"})}
    sc_res.evidence = {**ev, "given": sorted(given & {"motor_log_lag"})}
    series = {"t_s": M.t_s[m], "stat": y}
    lag_res.series = {**series, "base": np.full_like(y, mu_l if with_scale else 0.0), "ext": G[j] + mu_l}
    sc_res.series = {
        **series,
        "base": G[jl] if jl is not None else np.zeros_like(y),
        "ext": (G[jl] if jl is not None else 0.0) + np.full_like(y, np.log(scale)),
    }
    return lag_res, sc_res
