"""One held-out likelihood test per catalog cause.

Every cause is tested the same way. The CPIs are cut into alternating blocks of
``block_cpis`` (folds A and B). On each fold the paper's model (baseline) and the
model extended by the cause are fitted, and both are scored on the *other* fold by
the log-likelihood of the cause's statistic. The two held-out likelihood ratios are
averaged: under the baseline the average has expectation <= 1 whatever was fitted
(each ratio is a likelihood ratio on data its fit did not see), so it is an e-value
and P(ratio >= 1/a) <= a (Markov). A cause is *significant* when its log e-value
exceeds the threshold of its greedy step (``core.step_threshold``: Bonferroni over the
causes at level alpha / (k (k + 1)) at step k) and *relevant* when its fitted effect
is at least a margin (a fraction of the catalog's detectable size). ``core.decide_all``
names causes greedily, strongest first, each later step testing the remaining causes
with the named causes' extensions in both models (``given`` of :func:`test_log`; the
other statistics are unchanged by another cause's extension, see ``core.COUPLED``).

Sizes and correlation times of the fluctuating causes are estimated jointly and
analytically (:mod:`.timescales`: variogram of the per-window dB series, window
averaging and noise accounted for), without simulating any process: the body's on
short windows (:func:`.measure.body_power_fine`), the fading's on short windows too
(:func:`fading_estimate_fine`: the harmonics' cluster powers on windows of n_fft / 2
pulses, the rotors' beats taken out as a nuisance measured where the fading
cancels, exact likelihood), on the CPIs where too few short windows are usable
(:func:`fading_estimate`), both after taking out the tilt of the harmonics by the
rotor-speed changes. The fading is named by the CPI grid's size (as before the
short windows).

A test's ``held_out`` records whether its ``nll_base``/``nll_ext`` really are held-out
scores: both folds held observations, each was scored with parameters fitted on the
other alone, the scores are finite, and no fit borrowed data outside its fold (the
fading test's within-CPI scatter falls back to the whole flight when a fold has too
few multi-harmonic CPIs). Only held-out tests can be significant. The shared
preprocessing (linear trend in time and log range, the body's moving average, the
rotor-speed tilt of the harmonics, fitted where a common gain cancels) is computed
once on the whole flight and is the same for both models.

Statistics (per CPI) and models:

- ``sideband_asymmetry``: d = 10 log10(upper / lower sideband power) over the usable
  harmonic pairs; baseline N(0, s^2), extension N(a, s^2).
- ``sideband_fading``: mean over the harmonics (pairs counted by their summed power)
  of each pair's power relative to its median [dB], with the paper's envelope's
  tilt by the rotor speed taken out (:func:`speed_tilt`), detrended for time and
  range; baseline N(0, within-CPI scatter / K + m^2), extension adds a fitted variance.
- ``body_fluctuation``: body power [dB], detrended, same models.
- ``motor_log_lag`` / ``motor_speed_scale``: y = ln(measured HERM spacing / the one the
  log predicts at that CPI); baseline N(0, s^2), lag N(ln f(t+lag)/f(t), s^2), scale
  N(ln scale, s^2), each contaminated by 5 % outliers (a wide normal, the same in both
  models); with the other one named, it is in both models (:func:`test_log`).
- ``phase_noise``: Whittle likelihood of the periodogram ordinates near the clutter
  line (off the target's lines): baseline PSD = the background recording's, extension
  adds a skirt (line power) / 200 Hz x (q_flat + q_slope (50 Hz / f)^2) around the
  clutter line and the body (a flat, Gaussian-shaped or 1/f-like phase-noise spectrum
  is a mix of the two over 35-95 Hz); ``skirt_dbc_hz`` = 10 log10((q_flat + q_slope) /
  200 Hz) is its density at 50 Hz, ``rms_rad`` = sqrt(ln(1 + q_flat + q_slope)) the
  rms of the flat process with that skirt.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from ..synthesis.catalog import PHASE_NOISE_BANDWIDTH_HZ, SKIRT_OFFSET_HZ
from .features import DB, cpi_average
from .timescales import _lag_grid, fit_gain_process, fit_gain_process_ml, fit_variogram, harmonic_speed_slope

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


# ---------------------------------------------------------------- the tests

def usable_pairs(M, cfg):
    """Harmonic pairs whose weaker side is clearly above the noise in most CPIs."""
    with np.errstate(divide="ignore", invalid="ignore"):
        snr = np.minimum(M.up, M.lo) / np.maximum(np.maximum(M.up_sd, M.lo_sd), 1e-30)
    snr = np.where(M.pair_ok, snr, np.nan)
    med = np.array([np.nanmedian(c) if np.isfinite(c).any() else 0.0 for c in snr.T])
    return (med >= cfg.min_pair_snr) & (np.isfinite(snr).sum(axis=0) >= 6)


def usable_pair_sums(M, cfg):
    """Harmonic pairs whose summed power (upper + lower) is clearly above the noise in
    most CPIs: the fading statistic reads the sum, so a pair with one side weakened
    (an asymmetry) still counts."""
    with np.errstate(divide="ignore", invalid="ignore"):
        snr = (M.up + M.lo) / np.maximum(np.sqrt(M.up_sd ** 2 + M.lo_sd ** 2), 1e-30)
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
        res.evidence = {"reason": f"usable sideband pairs (median >= {cfg.min_pair_snr:g} dB over the floor) "
                                  f"in {int(m.sum())} CPIs (expected >= {2 * cfg.block_cpis}, two folds)"}
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


def _power_fluct_test(cause, y, sd0, m, M, cfg, fold, smooth=0):
    res = CauseTest(cause)
    if m.sum() < 2 * cfg.block_cpis + 4:
        res.testable = False
        res.evidence = {"reason": f"{int(m.sum())} usable CPIs (expected >= {2 * cfg.block_cpis + 4})"}
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
    res.series = {"t_s": M.t_s[m], "stat": e, "base": np.sqrt(v0), "ext": np.sqrt(v0 + s2)}
    res.evidence = {"measured_excess_std_db": round(meas_sd, 2),
                    "noise_std_db": round(float(np.sqrt(np.median(sd0[m] ** 2))), 3),
                    "residual_std_db": round(float(e.std()), 2)}
    return res, s2


def test_fading(M, cfg, fold, calib) -> CauseTest:
    """Common-mode (random-effects) test: a fading gain moves every harmonic together,
    while the paper's model leaves each harmonic's power to vary on its own (beats of
    the rotors' lines). The baseline variance of the CPI's mean harmonic power [dB]
    is the within-CPI scatter across harmonics / K.

    The paper's envelope exp(-alpha |f|) also moves the harmonics with the rotor
    speed, harmonic n by n beta u dB for a speed change u (:func:`speed_tilt`): that
    is not independent across the harmonics, and their mean moves by n_mean beta u,
    which the within-CPI scatter does not see. It is the paper's model (alpha
    calibrated on the flight, :func:`envelope_tilt`), so it is taken out of every
    harmonic before the statistic is formed (both models). With a steep fall-off it
    is large: 10 dB per harmonic beyond the wire's own roll-off at the hover speed f0
    (60 rev/s) gives beta = -10 dB / f0 = -0.16 dB per rev/s, so a speed std of 4-5
    rev/s moves the mean of harmonics 1-3 by 1.3-1.6 dB: clean flights of the
    world v2 (fall-off 10-16 dB, sidebands ending after one or two pairs) showed a
    held-out log e-value of 10-40 without it (-1 to 5 with it; threshold 7.1)."""
    res = CauseTest("sideband_fading", statistic="mean sideband-pair power [dB], common to all harmonics")
    use = usable_pair_sums(M, cfg)
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
    beta, u = speed_tilt(M, x, ok, m, use)
    x = x - beta * np.asarray(M.harm, float)[None, :] * u[:, None]
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
    # size and correlation time jointly, from the variogram of the common-mode series
    # with the rotor-speed tilt taken out (fading_estimate)
    est = fading_estimate(M, x, ok, m, beta=0.0)  # x has the tilt out already
    est["speed_tilt_db"] = beta
    cpi_sd = float(est["sigma_db"]) if s2 > 0 else 0.0
    # on short windows where enough are usable (fading_estimate_fine); the CPI grid's otherwise
    fine = fading_estimate_fine(M, ok, m, beta, u) if cpi_sd > 0 else None
    if fine is not None:
        true_sd, tau = float(fine["sigma_db"]), float(fine["timescale_s"])
    else:
        true_sd = cpi_sd
        tau = float(est["timescale_s"]) if true_sd > 0 and np.isfinite(est["timescale_s"]) else float("nan")
    res.params = {"fading_std_db": true_sd, "timescale_s": tau}
    res.effect = true_sd
    # named by the CPI grid's size (the naming as before the short windows)
    res.relevant = cpi_sd >= cfg.margin_std_db
    res.series = {"t_s": M.t_s[m], "stat": e, "base": np.sqrt(v0), "ext": np.sqrt(v0 + s2)}
    res.evidence = {"fading_std_db": round(true_sd, 2), "timescale_s": round(tau, 2),
                    "variogram_lags_s": [round(x, 3) for x in est["lags_s"]],
                    "variogram_db2": [round(x, 3) for x in est["variogram_db2"]],
                    "speed_tilt_db_per_harmonic_rev_s": round(est["speed_tilt_db"], 4),
                    "measured_common_std_db": round(meas_sd, 2),
                    "within_cpi_harmonic_std_db": round(float(np.sqrt(s2w)), 2),
                    "n_pairs_used": int(use.sum()),
                    "estimate_grid": "short windows" if fine is not None else "CPI",
                    "cpi_grid_fading_std_db": round(cpi_sd, 2),
                    "cpi_grid_timescale_s": round(float(est["timescale_s"]), 2)}
    return res


def _speed_tilt_fit(M, x, ok, m):
    """(beta, u [n_t], Y [n_t, N], V [n_t, N]): each harmonic's series ``x`` [dB]
    detrended in time and log range (Y, valid where V), the motor log's mean speed
    likewise (u [rev/s], 0 off ``m``), and the slope beta of Y on n u
    (:func:`.timescales.harmonic_speed_slope`)."""
    t, r = M.t_s, M.range_m
    n_t, N = x.shape
    Y = np.zeros((n_t, N))
    V = np.zeros((n_t, N), bool)
    for k in range(N):
        v = m & ok[:, k]
        if v.sum() >= 4:
            Y[v, k] = _detrend(x[v, k], t[v], r[v])
            V[:, k] = v
    u = np.zeros(n_t)
    if m.sum() >= 4:
        u[m] = _detrend(np.asarray(M.f_log_hz, float)[m], t[m], r[m])
    return harmonic_speed_slope(Y, V, np.asarray(M.harm, float), u), u, Y, V


def measured_speed(M) -> np.ndarray:
    """Mean rotor speed [rev/s] per CPI as the measured HERM line spacing shows it:
    the motor log's (CPI-averaged) times the measured / logged spacing (``M.dil``,
    interpolated in time over the CPIs where it was matched, ``M.dil_ok``); the log's
    alone where fewer than 4 CPIs matched. A late or scaled log (motor_log_lag,
    motor_speed_scale) leaves it unchanged: the envelope's tilt follows the rotors'
    true speed, not the log's."""
    f = np.asarray(M.f_log_hz, float)
    d = np.asarray(M.dil, float)
    good = np.asarray(M.dil_ok, bool) & np.isfinite(d) & (d > 0)
    if good.sum() < 4:
        return f
    return f * np.interp(M.t_s, M.t_s[good], d[good])


def envelope_tilt(M, use) -> float:
    """The paper's envelope exp(-alpha |f|) as a tilt of the harmonics by the rotor
    speed: harmonic n's sideband-pair power moves by n beta u dB for a change u
    [rev/s] of the rotor speed, beta = -20 log10(e) alpha B [dB per harmonic number
    per rev/s] (B blades). alpha is the paper's, calibrated on this flight like
    ``core._calibrate`` but on the pairs' summed power (the harmonics ``use``): the
    slope of each harmonic's median measured / model power [dB] (the model without
    envelope, so the wire's own roll-off is out) over its frequency n B f (f the
    median logged speed), clipped to a decaying envelope (beta <= 0). A fading is
    common to all the harmonics and leaves the medians' slope alone.

    Not fitted to the fluctuations: on flights whose sidebands end after one or two
    pairs, the slope of the harmonics' deviations from their CPI mean on the speed
    (:func:`.timescales.harmonic_speed_slope`) rests on the few CPIs where two pairs
    are seen at once, and on the paper world's steep fall-offs came out up to twice
    the measured per-harmonic slope (-0.31 against -0.14 to -0.19 dB per rev/s and
    harmonic number, calibrated -0.15), which left the speed in the common mode."""
    hbar = float(np.median(measured_speed(M))) * M.info["n_blades"]
    ks, g = [], []
    for k in np.flatnonzero(use):
        mk = M.valid & M.pair_ok[:, k] & (M.model_h[:, k] > 0) & (M.up[:, k] + M.lo[:, k] > 0)
        if mk.sum() >= 4:
            ks.append(k)
            g.append(float(np.median((M.up[mk, k] + M.lo[mk, k]) / (2 * M.model_h[mk, k]))))
    if len(ks) < 2 or not hbar > 0:
        return 0.0
    slope = np.polyfit(np.asarray(M.harm, float)[ks] * hbar, DB * np.log(g), 1)[0]  # dB per Hz
    return float(min(slope, 0.0) * M.info["n_blades"])


def speed_tilt(M, x, ok, m, use) -> tuple[float, np.ndarray]:
    """The paper's envelope seen in the harmonics' sideband-pair powers ``x`` [dB,
    n_t x N] (valid where ``ok``, CPIs ``m``, harmonics ``use``): harmonic n moves by
    n beta u dB for a change u [rev/s] of the rotors' mean speed (the measured one,
    :func:`measured_speed`, so that a late or scaled log does not enter the fading
    statistic; detrended in time and log range like the statistic). Returns (beta
    (:func:`envelope_tilt`), u [n_t] (0 off ``m``))."""
    t, r = M.t_s, M.range_m
    u = np.zeros(len(t))
    if m.sum() >= 4:
        u[m] = _detrend(measured_speed(M)[m], t[m], r[m])
    return envelope_tilt(M, use), u


def fading_estimate(M, x, ok, m, beta: float | None = None) -> dict:
    """Size [dB] and 1/e correlation time [s] of the fading, jointly
    (:func:`.timescales.fit_gain_process` on the CPI grid: analytic CPI-window
    averaging), from the harmonics' sideband-pair powers ``x`` [dB, n_t x N] (valid
    where ``ok``, CPIs ``m``).

    Each harmonic's series is detrended linearly in time and log range. Then the
    rotor-speed tilt is taken out: under the paper's envelope exp(-alpha |f|) a
    change u of the mean rotor speed (the motor log's, CPI-averaged) moves harmonic
    n's power by n beta u dB; beta is the given one (``test_fading`` passes the
    calibrated envelope's, :func:`envelope_tilt`, on ``x`` with the tilt already
    out: ``beta=0``), else fitted on the harmonics' deviations from their CPI mean,
    where a common gain cancels (:func:`.timescales.harmonic_speed_slope`).
    Without it, the speed changes of a flight (a few % of the rotor speed, over
    seconds) enter the common-mode series as a second fluctuation that is not the
    fading, and shorten its fitted time. The fit reads the variogram of the mean
    over the harmonics, with a noise nugget up to the within-CPI scatter across the
    harmonics / K (what each harmonic does on its own: measurement noise, the beats
    of the rotors' lines within its cluster; an upper bound, as part of that
    scatter is slow). No drift term: on the CPI grid a slow drift and a fading of a
    few seconds cannot be told apart, and the blades have no aspect term of their own.
    """
    t, r = M.t_s, M.range_m
    n_t, N = x.shape
    harm = np.asarray(M.harm, float)
    fitted, u, Y, V = _speed_tilt_fit(M, x, ok, m)
    beta = fitted if beta is None else float(beta)
    Y = np.where(V, Y - beta * harm[None, :] * u[:, None], 0.0)
    Kt = V.sum(axis=1)
    mm = m & (Kt >= 1)
    c = Y.sum(axis=1) / np.maximum(Kt, 1)
    multi = mm & (Kt >= 2)
    ss = np.where(V, (Y - c[:, None]) ** 2, 0.0).sum(axis=1)
    s2w = float(ss[multi].sum() / max((Kt[multi] - 1).sum(), 1)) if multi.any() else 0.0
    yy = np.zeros(n_t)
    nv = np.zeros(n_t)
    if mm.sum() >= 4:
        yy[mm] = _detrend(c[mm], t[mm], r[mm])
        nv[mm] = s2w / Kt[mm]
    est = fit_gain_process(yy, mm.copy(), nv, float(np.median(np.diff(t))), M.stft.window, M.info["prf_hz"],
                           drift=False, noise_free=True)
    est["speed_tilt_db"] = beta
    return est


def fading_estimate_fine(M, ok, m, beta: float, u: np.ndarray, *, min_windows: int = 200,
                         max_lag_s: float = 10.0) -> dict | None:
    """Size [dB] and 1/e correlation time [s] of the fading from the short-window
    sideband powers (:func:`.measure.sideband_power_fine`, ``M.side_fine``), or None
    when fewer than ``min_windows`` windows are usable (the caller then keeps the CPI
    grid's :func:`fading_estimate`).

    A window's harmonic is used where its nearest CPI uses it (``ok`` [n_t, N],
    CPIs ``m``); its dB series is 10 log10 of the summed upper + lower cluster
    power (at least one noise std), detrended linearly in time and log range, with
    the rotor-speed tilt n ``beta`` u taken out (``u`` [n_t] the CPIs' speed
    deviation, interpolated to the windows; :func:`speed_tilt`). The statistic is
    the mean over the usable harmonics, detrended again.

    In a short window the four rotors' lines of a cluster are not resolved and
    their power beats (n x a few Hz): a nuisance of 2-10 dB^2 per harmonic, white on
    the window grid (its variogram is flat from one hop on) and independent between
    the harmonics, like the measurement noise. Its variance is measured where the
    fading cancels, in the harmonics' deviations from their mean: for pairs of
    windows L = 1-4 hops apart, over the K >= 2 harmonics usable in both, the
    increments d_k and their mean d give n = mean[sum_k (d_k - d)^2 / (2 (K - 1))]
    (unbiased whatever each harmonic's level); the mean of K harmonics carries
    n / K.

    The fading's (sigma, T) are then the exact Gaussian likelihood's
    (:func:`.timescales.fit_gain_process_ml`: window-averaged exponential
    correlation plus the white nuisance n / K and a free white variance w, the part of
    the beats common to the harmonics, which their differences do not see: with w
    left out, an OU fading under four rotors 1-3 % apart came out ~16 % short;
    restricted to the residual of the
    trend in time and log range; T up to the longest lag / 2.5; where it still
    rises there, the variogram's estimate is kept), started from the variogram fit
    with the nuisance subtracted lag by lag (gamma(L) = mean[d^2 / 2] - n(L)
    mean[1 / K], :func:`.timescales.fit_variogram`, no nugget, no drift). Tuned on
    plans 777-780 (benchmarks/README.md, "Fading timescale on short windows")."""
    F = getattr(M, "side_fine", None)
    if F is None or m.sum() < 4:
        return None
    j = F["cpi"]
    harm = np.asarray(M.harm, float)
    P = F["up"] + F["lo"]
    sd = np.sqrt(F["up_sd"] ** 2 + F["lo_sd"] ** 2)
    V = F["inside"] & ok[j] & m[j][:, None]
    y = DB * np.log(np.maximum(P, np.maximum(sd, 1e-30)))
    t, r = F["t_s"], F["range_m"]
    uf = np.interp(t, M.t_s[m], u[m])
    Y = np.zeros_like(y)
    for k in range(y.shape[1]):
        v = V[:, k]
        if v.sum() >= 20:
            Y[v, k] = _detrend(y[v, k], t[v], r[v]) - beta * harm[k] * uf[v]
        else:
            V[:, k] = False
    Kt = V.sum(1)
    use = Kt >= 1
    if use.sum() < min_windows:
        return None
    lags = _lag_grid(len(t), F["hop_s"], max_lag_s)
    g, npair, nh = [], [], {}
    for L in lags:
        Vc = V[:-L] & V[L:]
        K = Vc.sum(1)
        D = np.where(Vc, Y[L:] - Y[:-L], 0.0)
        s1 = K >= 1
        s2 = K >= 2
        if s2.sum() < 20:
            g.append(np.nan); npair.append(0)
            continue
        d = D.sum(1) / np.maximum(K, 1)
        dd = np.where(Vc, D - d[:, None], 0.0)
        nh[int(L)] = 0.5 * float(np.mean((dd[s2] ** 2).sum(1) / (K[s2] - 1)))
        g.append(0.5 * float(np.mean(d[s1] ** 2)) - nh[int(L)] * float(np.mean(1.0 / K[s1])))
        npair.append(int(s1.sum()))
    est = fit_variogram(lags, np.array(g), np.array(npair), 0.0, F["hop_s"], F["window"], M.info["prf_hz"],
                        drift=False)
    short = [nh[L] for L in (1, 2, 3, 4) if L in nh]
    if not (est["sigma_db"] > 0 and np.isfinite(est["timescale_s"])) or not short:
        return None
    n_h = float(np.mean(short))
    c = np.zeros(len(t))
    c[use] = _detrend(np.where(V, Y, 0.0).sum(1)[use] / Kt[use], t[use], r[use])
    # T searched up to the longest lag / 2.5, as the variogram fit (beyond, sigma and T trade off)
    t_hi = min(30.0, float(lags[-1]) * F["hop_s"] / 2.5)
    ml = fit_gain_process_ml(c, use, np.where(use, n_h / np.maximum(Kt, 1), 0.0), F["hop_s"], F["window"],
                             M.info["prf_hz"], (est["sigma_db"], est["timescale_s"]), tau_bounds_s=(0.01, t_hi),
                             design=np.column_stack([np.ones(len(t)), t - t[use].mean(),
                                                     np.log10(r / r[use].mean())]), free_white=True)
    est["variogram_sigma_db"], est["variogram_timescale_s"] = est["sigma_db"], est["timescale_s"]
    # a likelihood still rising at the longest T searched has not seen the sill (a
    # record of a few tens of T): the variogram's estimate is kept there
    if ml["n_eval"] > 0 and ml["timescale_s"] < 0.98 * t_hi:
        est["sigma_db"], est["timescale_s"] = ml["sigma_db"], ml["timescale_s"]
    est["nuisance_db2_per_harmonic"] = n_h
    est["common_white_db2"] = float(ml.get("extra_white_db2", 0.0))
    est["n_windows"] = int(use.sum())
    return est


def body_estimate(M) -> dict:
    """Size [dB] and 1/e correlation time [s] of the body power's fluctuation, from the
    short-window body power series (:func:`.measure.body_power_fine`), detrended
    linearly in time and log range (:func:`.timescales.fit_gain_process`)."""
    F = M.body_fine
    v = F["valid"]
    y = np.zeros(len(v))
    if v.sum() >= 20:
        y[v] = _detrend(F["y_db"][v], F["t_s"][v], F["range_m"][v])
    # no drift term: tried on emulated (aspect 1 dB, 4 s) and independent flights, a
    # free drift took part of any fluctuation slower than ~0.5 s (sizes 20-35 % low)
    return fit_gain_process(y, v, F["noise_var_db2"], F["hop_s"], F["window"], M.info["prf_hz"], drift=False)


def test_body(M, cfg, fold) -> CauseTest:
    m = M.valid & (M.body_pow > 0)
    y = np.where(m, DB * np.log(np.maximum(M.body_pow, 1e-30)), 0.0)
    res, s2 = _power_fluct_test("body_fluctuation", y, M.body_sd_db, m, M, cfg, fold, smooth=cfg.body_smooth_cpis)
    res.statistic = "body power [dB], detrended"
    if s2 is not None:
        est = body_estimate(M) if s2 > 0 else {"sigma_db": 0.0, "timescale_s": float("nan"), "lags_s": [],
                                               "variogram_db2": []}
        sd = float(est["sigma_db"])
        tau = float(est["timescale_s"]) if sd > 0 and np.isfinite(est["timescale_s"]) else float("nan")
        res.params = {"body_std_db": sd, "timescale_s": tau}
        res.effect = sd
        res.relevant = sd >= cfg.margin_body_std_db
        res.evidence.update({"body_std_db": round(sd, 2), "timescale_s": round(tau, 3),
                             "variogram_lags_s": [round(x, 3) for x in est["lags_s"]],
                             "variogram_db2": [round(x, 3) for x in est["variogram_db2"]]})
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


#: outlier fraction of the lag/scale tests' contaminated-normal likelihood
LOG_OUTLIER_FRAC = 0.05


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
    lags = np.arange(-cfg.max_lag_s, cfg.max_lag_s + 1e-9, cfg.lag_step_s)
    G = _lag_curves(M, lags)[:, m]
    with_scale = "motor_speed_scale" in given
    with_lag = "motor_log_lag" in given

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
        # both models are contaminated normals: a fraction LOG_OUTLIER_FRAC of the CPIs
        # may be outliers of the spacing match (speed steps, a line lost for a CPI),
        # N(0, 10 x the training fold's mean square); without it, a fold fitted on
        # smooth CPIs scores the other fold's few outliers at thousands of sigma
        def fit(sel):
            wide = 10.0 * float(np.mean(y[sel] ** 2)) + 1e-10
            return fit_joint(sel, *base_flags), fit_joint(sel, *ext_flags), wide

        def ll(x, mu, var, wide):
            return np.logaddexp(np.log1p(-LOG_OUTLIER_FRAC) + _gauss_ll(x, mu, var),
                                np.log(LOG_OUTLIER_FRAC) + _gauss_ll(x, 0.0, wide))

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
    ev = {"line_spacing_ratio": round(float(np.exp(np.median(y))), 4), "fitted_lag_s": round(lag, 3),
          "log_speed_range_hz": round(float(spd.max() - spd.min()), 2),
          "spacing_ratio_std": round(float(np.std(np.exp(y))), 4)}
    lag_res.evidence = {**ev, "given": sorted(given & {"motor_speed_scale"})}
    sc_res.evidence = {**ev, "given": sorted(given & {"motor_log_lag"})}
    series = {"t_s": M.t_s[m], "stat": y}
    lag_res.series = {**series, "base": np.full_like(y, mu_l if with_scale else 0.0), "ext": G[j] + mu_l}
    sc_res.series = {**series, "base": G[jl] if jl is not None else np.zeros_like(y),
                     "ext": (G[jl] if jl is not None else 0.0) + np.full_like(y, np.log(scale))}
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
        # the skirt: flat, and falling as (f0 / f)^2 (f0 = 50 Hz), around the clutter
        # line and the body both; a mix of the two follows a flat, a Gaussian or a
        # 1/f-like phase-noise spectrum between pn_inner_hz and pn_outer_hz
        db_ = np.abs(f[cc] - fb)
        slope_c = (SKIRT_OFFSET_HZ / np.maximum(af, 20.0)) ** 2
        slope_b = (SKIRT_OFFSET_HZ / np.maximum(db_, 20.0)) ** 2
        kern = np.column_stack([unit * (af < bw) + Bt * (db_ < bw), unit * slope_c + Bt * slope_b]
                               + [unit * np.exp(-af / d) for d in cfg.pn_nuisance_decay_hz]
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

    NQ = 2  # phase-noise columns (flat, sloped)

    def nll_x(x, sel, with_q):
        th = x if with_q else np.concatenate([np.zeros(NQ), x])
        v = S[sel] + Kn[sel] @ th
        return float(np.sum(np.log(v) + P[sel] / v))

    def fit_model(sel, with_q):
        from scipy.optimize import minimize

        n = Kn.shape[1] if with_q else Kn.shape[1] - NQ
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
        vb = S[sel] + Kn[sel][:, NQ:] @ xb
        ve = S[sel] + Kn[sel] @ xe
        return -(np.log(vb) + P[sel] / vb), -(np.log(ve) + P[sel] / ve)

    _crossfit(F, fit, score, res)
    xb, xe = fit(np.ones(len(P), bool))
    q_flat, q_slope = float(xe[0] / norm[0]), float(xe[1] / norm[1])
    q = q_flat + q_slope  # both columns are 1 at 50 Hz: the skirt there, relative, x 2 bw
    rms = float(np.sqrt(np.log1p(q)))
    inner = Kn[:, 0] > 0  # ordinates within 100 Hz of the clutter line
    v_b = S + Kn[:, NQ:] @ xe[NQ:]
    rise_meas = float(DB * np.log(np.mean(P[inner]) / np.mean(S[inner])))
    rise_model = float(DB * np.log(np.mean((v_b + Kn[:, :NQ] @ xe[:NQ])[inner]) / np.mean(v_b[inner])))
    # the skirt's density at 50 Hz relative to its line [1/Hz] (first order in q)
    skirt = float(DB * np.log(max(q, 1e-30) / (2 * bw)))
    res.params = {"rms_rad": rms, "skirt_dbc_hz": skirt}
    res.effect = rise_model
    res.relevant = rise_model >= cfg.margin_floor_rise_db
    res.evidence = {"floor_rise_db_vs_background": round(rise_meas, 2), "model_floor_rise_db": round(rise_model, 2),
                    "rms_rad": round(rms, 4), "skirt_dbc_hz": round(skirt, 2),
                    "n_ordinates": int(len(P)),
                    "skirt_flat_and_sloped": [round(q_flat, 6), round(q_slope, 6)],
                    "nuisance_clutter_spread": [round(float(v), 4) for v in xe[NQ:]]}
    return res


CAUSE_ORDER = ("sideband_asymmetry", "sideband_fading", "body_fluctuation", "motor_log_lag",
               "motor_speed_scale", "phase_noise")
