"""One held-out likelihood test per catalog cause.

Every cause is tested the same way. The CPIs are cut into alternating blocks of
``block_cpis`` (folds A and B). On each fold the paper's model (baseline) and the
model extended by the cause are fitted, and both are scored on the *other* fold by
the log-likelihood of the cause's statistic. The two held-out likelihood ratios are
averaged: under the baseline the average has expectation <= 1 whatever was fitted
(each ratio is a likelihood ratio on data its fit did not see), so it is an e-value
and P(ratio >= 1/a) <= a (Markov). A cause is *significant* when its log e-value
exceeds ln(n_causes / alpha) (Bonferroni over the causes) and *relevant* when its
fitted effect is at least a margin (a fraction of the catalog's detectable size);
the named cause is the significant and relevant one with the largest e-value.

A test's ``held_out`` records whether its ``nll_base``/``nll_ext`` really are held-out
scores: both folds held observations, each was scored with parameters fitted on the
other alone, the scores are finite, and no fit borrowed data outside its fold (the
fading test's within-CPI scatter falls back to the whole flight when a fold has too
few multi-harmonic CPIs). Only held-out tests can be significant. The shared
preprocessing (linear trend in time and log range, the body's moving average) is
computed once on the whole flight and is the same for both models.

Statistics (per CPI) and models:

- ``sideband_asymmetry``: d = 10 log10(upper / lower sideband power) over the usable
  harmonic pairs; baseline N(0, s^2), extension N(a, s^2).
- ``sideband_fading``: blade power over the model's prediction [dB], detrended for
  range; baseline N(0, noise^2 + m^2), extension adds a fitted variance.
- ``body_fluctuation``: body power [dB], detrended, same models.
- ``motor_log_lag`` / ``motor_speed_scale``: y = ln(measured HERM spacing / the one the
  log predicts at that CPI); baseline N(0, s^2), lag N(ln f(t+lag)/f(t), s^2), scale
  N(ln scale, s^2).
- ``phase_noise``: Whittle likelihood of the periodogram ordinates near the clutter
  line (off the target's lines): baseline PSD = the background recording's, extension
  adds a flat skirt q * (line power) / 200 Hz around the clutter line and the body.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy.optimize import minimize_scalar

from ..catalog import PHASE_NOISE_BANDWIDTH_HZ
from ..extensions import BODY_TIMESCALE_S
from ..processes import ou_process
from .features import DB, cpi_average

LOG2PI = np.log(2 * np.pi)


@dataclass
class CauseTest:
    """Result of one cause's test."""

    cause: str
    log_e: float = 0.0                  # log of the averaged held-out likelihood ratio
    nll_base: float = np.nan            # held-out negative log-likelihood per observation
    nll_ext: float = np.nan
    n_obs: int = 0
    held_out: bool = False              # nll_base/nll_ext really scored on data the fits did not see
    params: dict = field(default_factory=dict)   # fitted on the whole flight
    effect: float = 0.0                 # size compared with the relevance margin
    relevant: bool = False
    testable: bool = True
    statistic: str = ""
    evidence: dict = field(default_factory=dict)
    series: dict = field(default_factory=dict)   # per-CPI series for the figure


def folds(n_t: int, block: int) -> np.ndarray:
    return (np.arange(n_t) // block) % 2


def _gauss_ll(x, mu, var):
    return -0.5 * (LOG2PI + np.log(var) + (x - mu) ** 2 / var)


def _crossfit(fold, fit, score, res: "CauseTest") -> None:
    """Two-fold cross-fit: ``fit(mask) -> theta`` on one fold, ``score(theta, mask) ->
    (ll_base, ll_ext)`` per observation on the other, and the other way round.

    Sets ``res.log_e`` (log of the averaged held-out likelihood ratio),
    ``res.nll_base``/``res.nll_ext`` (held-out negative log-likelihood per
    observation), ``res.n_obs`` and ``res.held_out``: True only when both folds hold
    observations (each fold scored with parameters fitted on the other one alone)
    and the scores are finite. A fit that has to borrow data outside its fold must
    clear ``res.held_out`` itself afterwards."""
    dl, nb, ne, n = [], 0.0, 0.0, 0
    held = True
    for k in (0, 1):
        train, test = fold == k, fold == 1 - k
        held &= bool(train.any() and test.any())
        th = fit(train)
        lb, le = score(th, test)
        lb, le = np.asarray(lb, float), np.asarray(le, float)
        held &= bool(np.all(np.isfinite(lb)) and np.all(np.isfinite(le)))
        dl.append(float(np.sum(le - lb)))
        nb -= float(np.sum(lb)); ne -= float(np.sum(le)); n += len(lb)
    m = max(dl)
    log_e = m + np.log(0.5 * sum(np.exp(d - m) for d in dl)) if np.isfinite(m) else float("nan")
    res.log_e, res.nll_base, res.nll_ext, res.n_obs = float(log_e), nb / max(n, 1), ne / max(n, 1), n
    res.held_out = bool(held and n > 0 and np.isfinite(log_e))


def _detrend(y, t, r, smooth: int = 0):
    """Remove a linear trend in time and log-range; with ``smooth`` > 1 also a
    centred moving average of that many CPIs (slow aspect changes)."""
    X = np.column_stack([np.ones_like(t), t - t.mean(), np.log10(r / r.mean())])
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    e = y - X @ beta
    if smooth > 1:
        e = e - _moving_average(e, smooth)
    return e


def _moving_average(x, w):
    k = np.ones(w) / w
    num = np.convolve(x, k, mode="same")
    den = np.convolve(np.ones_like(x), k, mode="same")
    return num / den


def _ml_extra_var(e, v0):
    """ML of the extra variance s2 >= 0 in e ~ N(0, v0 + s2)."""
    if len(e) < 3:
        return 0.0

    def nll(s2):
        v = v0 + s2
        return 0.5 * np.sum(np.log(v) + e ** 2 / v)

    hi = max(4 * float(np.mean(e ** 2)), 1e-6)
    r = minimize_scalar(nll, bounds=(0.0, hi), method="bounded", options={"xatol": 1e-4})
    s2 = float(r.x)
    return s2 if nll(s2) < nll(0.0) else 0.0


# ---------------------------------------------------------------- window maps

@lru_cache(maxsize=32)
def _window_maps(n_t: int, hop_s: float, cpi_s: float, tau_s: float, smooth: int = 0, seed: int = 12345):
    """Std [dB] of the CPI-averaged power of an OU dB gain (after linear detrending)
    for a grid of true stds, and the lag-2-CPI autocorrelation, by simulation."""
    from scipy.signal.windows import blackmanharris

    dt = 0.01
    dur = (n_t - 1) * hop_s + cpi_s
    n = int(np.ceil(dur / dt)) + 2
    tg = np.arange(n) * dt
    t_c = cpi_s / 2 + np.arange(n_t) * hop_s
    w = blackmanharris(256, sym=False)
    prf = 256 / cpi_s
    rng = np.random.default_rng(seed)
    grid = np.array([0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 14.0])
    base = np.array([ou_process(n, dt, 1.0, tau_s, rng) for _ in range(24)])
    meas_sd, rho2 = [], []
    for g in grid:
        sds, rs = [], []
        for b in base:
            p = cpi_average(tg, 10 ** (g * b / 10), t_c, w, prf)
            y = DB * np.log(p)
            y = y - np.polyval(np.polyfit(t_c - t_c.mean(), y, 1), t_c - t_c.mean())
            if smooth > 1:
                y = y - _moving_average(y, smooth)
            sds.append(y.std())
            rs.append(np.corrcoef(y[:-2], y[2:])[0, 1] if y.std() > 0 else 0.0)
        meas_sd.append(np.mean(sds))
        rho2.append(np.mean(rs))
    return grid, np.array(meas_sd), np.array(rho2)


def _invert_std(meas_sd: float, n_t, hop_s, cpi_s, tau_s, smooth: int = 0) -> float:
    grid, ms, _ = _window_maps(n_t, round(hop_s, 6), round(cpi_s, 6), round(tau_s, 3), smooth)
    return float(np.interp(meas_sd, ms, grid))


def _tau_from_rho2(rho2: float, n_t, hop_s, cpi_s) -> float:
    taus = np.array([0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0])
    r = np.array([_window_maps(n_t, round(hop_s, 6), round(cpi_s, 6), t)[2][5] for t in taus])  # at 3 dB
    order = np.argsort(r)
    return float(np.interp(rho2, r[order], taus[order]))


# ---------------------------------------------------------------- the tests

def usable_pairs(M, cfg):
    """Harmonic pairs whose weaker side is clearly above the noise in most CPIs."""
    with np.errstate(divide="ignore", invalid="ignore"):
        snr = np.minimum(M.up, M.lo) / np.maximum(np.maximum(M.up_sd, M.lo_sd), 1e-30)
    snr = np.where(M.pair_ok, snr, np.nan)
    med = np.array([np.nanmedian(c) if np.isfinite(c).any() else 0.0 for c in snr.T])
    return (med >= cfg.min_pair_snr) & (np.isfinite(snr).sum(axis=0) >= 6)


def test_asymmetry(M, cfg, fold) -> CauseTest:
    use = usable_pairs(M, cfg)
    ok = M.pair_ok & use[None, :]
    U = np.where(ok, M.up, 0).sum(1)
    L = np.where(ok, M.lo, 0).sum(1)
    m = M.valid & (U > 0) & (L > 0)
    res = CauseTest("sideband_asymmetry", statistic="upper/lower sideband power [dB]")
    if m.sum() < 2 * cfg.block_cpis:
        res.testable = False
        return res
    d = DB * np.log(U[m] / L[m])
    f = fold[m]

    def fit(sel):
        x = d[sel]
        return float(x.mean()), float(np.mean(x ** 2)) + 1e-6, float(x.var()) + 1e-6

    def score(th, sel):
        mu, vb, ve = th
        return _gauss_ll(d[sel], 0.0, vb), _gauss_ll(d[sel], mu, ve)

    _crossfit(f, fit, score, res)
    a = float(np.median(d))
    res.params = {"asymmetry_db": a}
    res.effect = abs(a)
    res.relevant = abs(a) >= cfg.margin_asymmetry_db
    per = {}
    for k, n in enumerate(M.harm):
        mk = M.valid & M.pair_ok[:, k] & (M.up[:, k] > 0) & (M.lo[:, k] > 0)
        if mk.sum() >= 4:
            per[f"h{int(n)}"] = round(float(np.median(DB * np.log(M.up[mk, k] / M.lo[mk, k]))), 2)
    res.evidence = {"asymmetry_db": round(a, 2), "asymmetry_per_harmonic_db": per,
                    "n_pairs_used": int(use.sum())}
    res.series = {"t_s": M.t_s[m], "stat": d, "base": np.zeros_like(d), "ext": np.full_like(d, a)}
    return res


def _power_fluct_test(cause, y, sd0, m, M, cfg, fold, tau_fixed=None, smooth=0):
    res = CauseTest(cause)
    if m.sum() < 2 * cfg.block_cpis + 4:
        res.testable = False
        return res, None
    e = _detrend(y[m], M.t_s[m], M.range_m[m], smooth)
    v0 = sd0[m] ** 2 + cfg.model_floor_db ** 2
    f = fold[m]

    def fit(sel):
        return _ml_extra_var(e[sel], v0[sel])

    def score(s2, sel):
        return _gauss_ll(e[sel], 0.0, v0[sel]), _gauss_ll(e[sel], 0.0, v0[sel] + s2)

    _crossfit(f, fit, score, res)
    s2 = _ml_extra_var(e, v0)
    meas_sd = float(np.sqrt(s2))
    hop_s = float(np.median(np.diff(M.t_s)))
    cpi_s = 2 * hop_s
    n_t = len(M.t_s)
    if tau_fixed is None:
        ee = np.zeros(n_t); ee[m] = e
        mm = m[:-2] & m[2:]
        var_x = max(s2, 1e-9)
        cov2 = float(np.mean(ee[:-2][mm] * ee[2:][mm])) if mm.sum() > 4 else 0.0
        rho2 = float(np.clip(cov2 / var_x, 0.0, 0.99))
        tau = _tau_from_rho2(rho2, n_t, hop_s, cpi_s) if s2 > 0 else 1.5
    else:
        tau = tau_fixed
    true_sd = _invert_std(meas_sd, n_t, hop_s, cpi_s, tau, smooth) if s2 > 0 else 0.0
    res.series = {"t_s": M.t_s[m], "stat": e, "base": np.sqrt(v0), "ext": np.sqrt(v0 + s2)}
    res.evidence = {"measured_excess_std_db": round(meas_sd, 2),
                    "noise_std_db": round(float(np.sqrt(np.median(sd0[m] ** 2))), 3),
                    "residual_std_db": round(float(e.std()), 2)}
    return res, (true_sd, tau)


def test_fading(M, cfg, fold, calib) -> CauseTest:
    """Common-mode (random-effects) test: a fading gain moves every harmonic together,
    while the paper's model leaves each harmonic's power to vary on its own (beats of
    the rotors' lines, speed changes). The baseline variance of the CPI's mean
    harmonic power [dB] is the within-CPI scatter across harmonics / K."""
    res = CauseTest("sideband_fading", statistic="mean sideband-pair power [dB], common to all harmonics")
    use = usable_pairs(M, cfg)
    ok = M.pair_ok & use[None, :] & (M.up + M.lo > 0)
    x = np.where(ok, DB * np.log(np.maximum(M.up + M.lo, 1e-30)), np.nan)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        x = x - np.nanmedian(np.where(ok, x, np.nan), axis=0, keepdims=True)
        x = np.where(np.isfinite(x), x, np.nan)
    K = ok.sum(1)
    # CPIs with one usable pair count too; the within-CPI scatter comes from those with more
    m = M.valid & (K >= 1)
    if m.sum() < 2 * cfg.block_cpis + 4 or use.sum() < 2 or (M.valid & (K >= 2)).sum() < 6:
        res.testable = False
        res.evidence = {"reason": "fewer than 2 usable sideband pairs"}
        return res
    c = np.nanmean(np.where(ok, x, np.nan)[m], axis=1)
    dev = (np.where(ok, x, np.nan)[m] - c[:, None])
    Km = K[m].astype(float)
    ss = np.nansum(dev ** 2, axis=1)
    e = _detrend(c, M.t_s[m], M.range_m[m])
    f = fold[m]

    borrowed = []

    def sw2(sel):
        d = (Km[sel] - 1).sum()
        if d >= 4:
            return float(ss[sel].sum() / d)
        borrowed.append(True)  # too few multi-harmonic CPIs in the fold: the whole flight's scatter
        return float(ss.sum() / max((Km - 1).sum(), 1.0))

    def fit(sel):
        v0 = sw2(sel) / Km[sel] + cfg.model_floor_db ** 2
        return sw2(sel), _ml_extra_var(e[sel], v0)

    def score(th, sel):
        s2w, s2 = th
        v0 = s2w / Km[sel] + cfg.model_floor_db ** 2
        return _gauss_ll(e[sel], 0.0, v0), _gauss_ll(e[sel], 0.0, v0 + s2)

    _crossfit(f, fit, score, res)
    res.held_out = res.held_out and not borrowed
    s2w, s2 = fit(np.ones(len(e), bool))
    v0 = s2w / Km + cfg.model_floor_db ** 2
    meas_sd = float(np.sqrt(s2))
    hop_s = float(np.median(np.diff(M.t_s)))
    n_t = len(M.t_s)
    ee = np.zeros(n_t); ee[m] = e
    mm = m[:-2] & m[2:]
    cov2 = float(np.mean(ee[:-2][mm] * ee[2:][mm])) if mm.sum() > 4 else 0.0
    rho2 = float(np.clip(cov2 / max(s2, 1e-9), 0.0, 0.99))
    tau = _tau_from_rho2(rho2, n_t, hop_s, 2 * hop_s) if s2 > 0 else 1.5
    tau = float(np.clip(tau, 0.5, 4.0))
    true_sd = _invert_std(meas_sd, n_t, hop_s, 2 * hop_s, tau) if s2 > 0 else 0.0
    res.params = {"fading_std_db": true_sd, "timescale_s": tau}
    res.effect = true_sd
    res.relevant = true_sd >= cfg.margin_std_db
    res.series = {"t_s": M.t_s[m], "stat": e, "base": np.sqrt(v0), "ext": np.sqrt(v0 + s2)}
    res.evidence = {"fading_std_db": round(true_sd, 2), "timescale_s": round(tau, 2),
                    "measured_common_std_db": round(meas_sd, 2),
                    "within_cpi_harmonic_std_db": round(float(np.sqrt(s2w)), 2),
                    "n_pairs_used": int(use.sum())}
    return res


def test_body(M, cfg, fold) -> CauseTest:
    m = M.valid & (M.body_pow > 0)
    y = np.where(m, DB * np.log(np.maximum(M.body_pow, 1e-30)), 0.0)
    res, p = _power_fluct_test("body_fluctuation", y, M.body_sd_db, m, M, cfg, fold, tau_fixed=BODY_TIMESCALE_S,
                              smooth=cfg.body_smooth_cpis)
    res.statistic = "body power [dB], detrended"
    if p is not None:
        res.params = {"body_std_db": p[0]}
        res.effect = p[0]
        res.relevant = p[0] >= cfg.margin_body_std_db
        res.evidence["body_std_db"] = round(p[0], 2)
    return res


def _lag_curves(M, lags):
    """g[l, t] = ln f_log(t + lag_l) - ln f_log(t) (CPI-averaged mean log speed)."""
    st = M.stft
    prf = M.info["prf_hz"]
    lg = M.log
    tl = lg.time_s
    fl = lg.rev_s.mean(axis=1)
    # smooth like the sub-CPI sampling would (CPI-average), on shifted CPI centres
    base = cpi_average(tl, fl, M.t_s, st.window, prf)
    out = np.empty((len(lags), len(M.t_s)))
    for i, L in enumerate(lags):
        out[i] = np.log(cpi_average(tl, fl, M.t_s + L, st.window, prf) / base)
    return out


def test_log(M, cfg, fold) -> tuple[CauseTest, CauseTest]:
    m = M.dil_ok & M.valid
    lag_res = CauseTest("motor_log_lag", statistic="ln(measured / logged HERM spacing)")
    sc_res = CauseTest("motor_speed_scale", statistic="ln(measured / logged HERM spacing)")
    if m.sum() < 2 * cfg.block_cpis:
        lag_res.testable = sc_res.testable = False
        return lag_res, sc_res
    y = np.log(M.dil[m])
    f = fold[m]
    lags = np.arange(-cfg.max_lag_s, cfg.max_lag_s + 1e-9, cfg.lag_step_s)
    G = _lag_curves(M, lags)[:, m]

    def fit_lag(sel):
        sse = ((y[sel][None, :] - G[:, sel]) ** 2).sum(1)
        j = int(np.argmin(sse))
        return j, float(np.mean(y[sel] ** 2)) + 1e-10, float(sse[j] / sel.sum()) + 1e-10

    def score_lag(th, sel):
        j, vb, ve = th
        return _gauss_ll(y[sel], 0.0, vb), _gauss_ll(y[sel], G[j, sel], ve)

    def fit_sc(sel):
        x = y[sel]
        return float(x.mean()), float(np.mean(x ** 2)) + 1e-10, float(x.var()) + 1e-10

    def score_sc(th, sel):
        mu, vb, ve = th
        return _gauss_ll(y[sel], 0.0, vb), _gauss_ll(y[sel], mu, ve)

    _crossfit(f, fit_lag, score_lag, lag_res)
    _crossfit(f, fit_sc, score_sc, sc_res)
    sse = ((y[None, :] - G) ** 2).sum(1)
    j = int(np.argmin(sse))
    # parabolic refinement of the lag
    lag = float(lags[j])
    if 0 < j < len(lags) - 1:
        a, b, c = sse[j - 1], sse[j], sse[j + 1]
        if a - 2 * b + c > 0:
            lag += float(np.clip(0.5 * (a - c) / (a - 2 * b + c), -0.5, 0.5)) * cfg.lag_step_s
    scale = float(np.exp(np.median(y)))
    lag_res.params = {"lag_s": lag}
    lag_res.effect = abs(lag)
    lag_res.relevant = abs(lag) >= cfg.margin_lag_s
    sc_res.params = {"scale": scale}
    sc_res.effect = abs(scale - 1)
    sc_res.relevant = abs(scale - 1) >= cfg.margin_scale
    spd = M.f_log_hz[m]
    ev = {"line_spacing_ratio": round(scale, 4), "fitted_lag_s": round(lag, 3),
          "log_speed_range_hz": round(float(spd.max() - spd.min()), 2),
          "spacing_ratio_std": round(float(np.std(np.exp(y))), 4)}
    lag_res.evidence = dict(ev)
    sc_res.evidence = dict(ev)
    series = {"t_s": M.t_s[m], "stat": y, "base": np.zeros_like(y)}
    lag_res.series = {**series, "ext": G[j]}
    sc_res.series = {**series, "ext": np.full_like(y, np.log(scale))}
    return lag_res, sc_res


def test_phase_noise(M, cfg, fold, calib=None) -> CauseTest:
    res = CauseTest("phase_noise", statistic="Whittle likelihood of the floor near the clutter line")
    if M.bg_stft is None:
        res.testable = False
        res.evidence = {"reason": "no background/iq: the radar's own phase noise cannot be separated"}
        return res
    st, bg = M.stft, M.bg_stft
    df = st.bin_hz
    k = max(1, int(cfg.pn_smooth_bins))
    # the background recording is the same cell sequence: smooth it over
    # +-pn_smooth_cpis CPIs and +-k bins around each CPI (time-aligned)
    from scipy.ndimage import uniform_filter

    s_bg_t = uniform_filter(bg.p, size=(2 * cfg.pn_smooth_cpis + 1, 2 * k + 1), mode="nearest")
    f = st.f_hz
    region = (np.abs(f) >= cfg.pn_inner_hz) & (np.abs(f) <= cfg.pn_outer_hz)
    cols = np.flatnonzero(region)[:: cfg.pn_bin_step]
    rows = np.flatnonzero(M.valid)[::2]  # non-overlapping CPIs
    P, S, K, F = [], [], [], []
    clutter = (np.abs(f) <= cfg.pn_clutter_line_hz)
    bw = PHASE_NOISE_BANDWIDTH_HZ
    for i in rows:
        fb = M.f_body_hz[i]
        ff = f[cols]
        # off the target: its body skirt (+-100 Hz) and its HERM lines (guard a fraction of the spacing)
        keep = np.abs(ff - fb) > cfg.body_half_hz + cfg.pn_body_guard_hz
        spacing = M.f_log_hz[i] * (M.dil[i] if np.isfinite(M.dil[i]) else 1.0) * int(M.info.get("n_blades", 2))
        for n in range(1, 16):
            for sg in (1, -1):
                keep &= np.abs(ff - (fb + sg * n * spacing)) > cfg.pn_line_guard_frac * spacing
        if M.sim_stft is not None and calib is not None:
            # off the blade power the calibrated model predicts there (smeared lines too)
            d = ff - fb
            pred = (calib["blade_abs"] ** 2 * np.exp(-2 * calib["alpha_s"] * np.abs(d))
                    * np.interp(d, M.sim_stft.f_hz, M.sim_stft.p[i]))
            keep &= pred < M.floor[i] * 10 ** (cfg.pn_model_guard_db / 10)
        cc = cols[keep]
        if len(cc) < 5:
            continue
        C = max(float(st.p[i, clutter].sum() - clutter.sum() * M.floor[i]), 0.0)
        af = np.abs(f[cc])
        unit = df / (2 * bw) * C
        # columns: the phase-noise skirt (flat, |f| < 100 Hz) and nuisance shapes in both
        # models: wind-blown clutter (exponential decay from the clutter line)
        # and a skirt around the body (a fluctuating body spreads its own line)
        Bt = max(float(M.body_pow[i]), 0.0) * df / (2 * bw)
        g2 = cfg.pn_body_skirt_hz ** 2
        kern = np.column_stack([unit * (af < bw) + Bt * (np.abs(f[cc] - fb) < bw)] + [unit * np.exp(-af / d) for d in cfg.pn_nuisance_decay_hz]
                               + [Bt * g2 / ((f[cc] - fb) ** 2 + g2)])
        P.append(st.p[i, cc]); S.append(s_bg_t[min(i, len(s_bg_t) - 1), cc]); K.append(kern); F.append(np.full(len(cc), fold[i]))
    if len(P) < 4:
        res.testable = False
        res.evidence = {"reason": "no floor near the clutter line clear of the target"}
        return res
    P, S, F = map(np.concatenate, (P, S, F))
    K = np.concatenate(K, axis=0)
    norm = np.maximum(K.mean(axis=0), 1e-300) / S.mean()
    Kn = K / norm

    def nll_x(x, sel, with_q):
        th = x if with_q else np.concatenate([[0.0], x])
        v = S[sel] + Kn[sel] @ th
        return float(np.sum(np.log(v) + P[sel] / v))

    def fit_model(sel, with_q):
        from scipy.optimize import minimize

        n = Kn.shape[1] if with_q else Kn.shape[1] - 1
        if n == 0:
            return np.zeros(0)
        best = None
        for x0 in (np.full(n, 1e-3), np.full(n, 0.3)):
            r = minimize(nll_x, x0, args=(sel, with_q), method="L-BFGS-B", bounds=[(0, None)] * n)
            if best is None or r.fun < best.fun:
                best = r
        return best.x

    def fit(sel):
        return fit_model(sel, False), fit_model(sel, True)

    def score(th, sel):
        xb, xe = th
        vb = S[sel] + Kn[sel][:, 1:] @ xb
        ve = S[sel] + Kn[sel] @ xe
        return -(np.log(vb) + P[sel] / vb), -(np.log(ve) + P[sel] / ve)

    _crossfit(F, fit, score, res)
    xb, xe = fit(np.ones(len(P), bool))
    q = float(xe[0] / norm[0])
    rms = float(np.sqrt(np.log1p(q)))
    inner = Kn[:, 0] > 0  # ordinates within 100 Hz of the clutter line
    v_b = S + Kn[:, 1:] @ xe[1:]
    rise_meas = float(DB * np.log(np.mean(P[inner]) / np.mean(S[inner])))
    rise_model = float(DB * np.log(np.mean((v_b + Kn[:, 0] * xe[0])[inner]) / np.mean(v_b[inner])))
    res.params = {"rms_rad": rms}
    res.effect = rise_model
    res.relevant = rise_model >= cfg.margin_floor_rise_db
    res.evidence = {"floor_rise_db_vs_background": round(rise_meas, 2), "model_floor_rise_db": round(rise_model, 2),
                    "rms_rad": round(rms, 4), "n_ordinates": int(len(P)),
                    "nuisance_clutter_spread": [round(float(v), 4) for v in xe[1:]]}
    return res


CAUSE_ORDER = ("sideband_asymmetry", "sideband_fading", "body_fluctuation", "motor_log_lag",
               "motor_speed_scale", "phase_noise")
