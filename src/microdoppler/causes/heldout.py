"""The held-out test every cause's test uses, and the estimators they share.

Every cause is tested the same way (:func:`_crossfit`). The CPIs are cut into
alternating blocks of ``block_cpis`` (folds A and B, :func:`folds`). On each fold the
paper's model (baseline) and the model extended by the cause are fitted, and both are
scored on the *other* fold by the log-likelihood of the cause's statistic. The two
held-out likelihood ratios are averaged: under the baseline the average has
expectation <= 1 whatever was fitted, so it is an e-value. A test's ``held_out``
records whether its ``nll_base``/``nll_ext`` really are held-out scores.

Also here: the Gaussian and detrending helpers, the power-fluctuation test
(:func:`_power_fluct_test`) and the joint estimate of a slow dB gain's size and
correlation time (:func:`fit_gain_process`, :func:`fit_gain_process_ml`), which the
fluctuation causes share. See :mod:`microdoppler.diagnosis.hypotheses` for how the
tests are run and :mod:`microdoppler.diagnosis.decide` for how causes are named.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

LOG2PI = np.log(2 * np.pi)


@dataclass
class CauseTest:
    """Result of one cause's test."""

    cause: str
    log_e: float = 0.0  # log of the averaged held-out likelihood ratio
    nll_base: float = np.nan  # held-out negative log-likelihood per observation
    nll_ext: float = np.nan
    n_obs: int = 0
    held_out: bool = False  # nll_base/nll_ext really scored on data the fits did not see
    params: dict = field(default_factory=dict)  # fitted on the whole flight
    effect: float = 0.0  # size compared with the relevance margin
    relevant: bool = False
    testable: bool = True
    statistic: str = ""
    evidence: dict = field(default_factory=dict)
    series: dict = field(default_factory=dict)  # per-CPI series for the figure
    fit: dict = field(default_factory=dict)  # fitted model other tests condition on (phase noise: its skirt)


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
        nb -= float(np.sum(lb))
        ne -= float(np.sum(le))
        n += len(lb)
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
        return 0.5 * np.sum(np.log(v) + e**2 / v)

    hi = max(4 * float(np.mean(e**2)), 1e-6)
    r = minimize_scalar(nll, bounds=(0.0, hi), method="bounded", options={"xatol": 1e-4})
    s2 = float(r.x)
    return s2 if nll(s2) < nll(0.0) else 0.0


def _power_fluct_test(cause, y, sd0, m, M, cfg, fold, smooth=0):
    res = CauseTest(cause)
    if m.sum() < 2 * cfg.block_cpis + 4:
        res.testable = False
        res.evidence = {"reason": f"{int(m.sum())} usable CPIs (expected >= {2 * cfg.block_cpis + 4})"}
        return res, None
    e = _detrend(y[m], M.t_s[m], M.range_m[m], smooth)
    v0 = sd0[m] ** 2 + cfg.model_floor_db**2
    f = fold[m]

    def fit(sel):
        return _ml_extra_var(e[sel], v0[sel])

    def score(s2, sel):
        return _gauss_ll(e[sel], 0.0, v0[sel]), _gauss_ll(e[sel], 0.0, v0[sel] + s2)

    _crossfit(f, fit, score, res)
    s2 = _ml_extra_var(e, v0)
    meas_sd = float(np.sqrt(s2))
    res.series = {"t_s": M.t_s[m], "stat": e, "base": np.sqrt(v0), "ext": np.sqrt(v0 + s2)}
    res.evidence = {
        "measured_excess_std_db": round(meas_sd, 2),
        "noise_std_db": round(float(np.sqrt(np.median(sd0[m] ** 2))), 3),
        "residual_std_db": round(float(e.std()), 2),
    }
    return res, s2


# ---------------------------------------------------------------- sizes and correlation times
# Size and correlation time of a slow dB gain, jointly, from a windowed power series.
#
# A gain g(t) = 10^(x(t)/10) on a power, x Gaussian in dB with standard deviation
# ``sigma`` [dB] and correlation exp(-|tau| / T) (T the 1/e correlation time [s]), is
# seen through analysis windows: each sample of the series is 10 log10 of the
# window-weighted average of g over the window (power weights w^2, normalised), plus
# measurement noise. Nothing here simulates the process: the covariance of the
# measured dB series is computed analytically.
#
# For two windows centred ``L`` apart the averaged powers P_i are sums of correlated
# log-normals: E[P] = exp(b^2 s^2 / 2) with b = ln 10 / 10 and
#
#     Cov(P_i, P_j) / E[P]^2 = sum_{k,l} w_k w_l (exp(b^2 s^2 rho(L + u_k - u_l)) - 1),
#
# (u_k the offsets of the window's points). Approximating each P_i as log-normal
# (Fenton-Wilkinson moment matching), the dB series has covariance
#
#     c(L) = ln(1 + Cov(P_i, P_j) / E[P]^2) / b^2   [dB^2],
#
# exact when T is long against the window (no averaging) and a moment match when it
# is short. The estimator fits (sigma, T) to the *variogram* of the series,
# gamma(L) = (1/2) mean (y_{i+L} - y_i)^2 over pairs of valid samples, at lags of 1, 2,
# 3, 4, 6, 8, ... hops up to ``max_lag_s``: gamma(L) = c(0) - c(L) + noise (the noise's
# variance, known per sample from the measurement; windows overlapping by 50 % leave
# the noise of neighbours almost uncorrelated: 0.14 % for Blackman-Harris). The
# variogram ignores a constant and is hardly moved by slow trends; slower variations
# (aspect changes, range-cell straddle) enter as a nuisance drift kappa L. The fit minimises
# the squared log-ratio of measured and model variogram over the lags (a grid over
# sigma, T and kappa, then a finer one), so every lag counts by its relative error,
# for two correlation shapes (exponential and Matern 3/2, :data:`SHAPES`; the better
# fit is kept; T is always the 1/e time).
#
# For a gain common to several harmonics' sideband powers (the fading),
# :func:`harmonic_speed_slope` first measures how the rotor speed tilts the harmonics
# against each other (the paper's envelope exp(-alpha |f|) moves harmonic n by n beta u
# dB for a speed change u), from the harmonics' deviations from their mean, where the
# common gain cancels; the caller takes n beta u out before forming the common-mode
# series.
#
# On a grid much finer than T, :func:`fit_gain_process_ml` maximises the exact Gaussian
# likelihood of the same model (window-averaged exponential correlation plus white
# noise of known variance per sample), which weighs the short lags by their
# information; the variogram fit gives its start.
#
# Limits: when T is much shorter than a window only sigma^2 T is identifiable (the
# series is white); T is searched up to the longest lag / 2.5 (4 s by default); when
# T nears the record length / 10 the sill is poorly sampled (few independent
# stretches), so sigma is uncertain by ~sqrt(2 T / duration). The shape is assumed
# exponential: for another shape T is the exponential's that fits the variogram best.

B = np.log(10.0) / 10.0
#: grid of correlation times searched [s]
TAU_GRID_S = np.exp(np.linspace(np.log(0.01), np.log(30.0), 70))


def window_offsets(window: np.ndarray, prf_hz: float, n_points: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Pairwise offset differences u_k - u_l [s] and their weights w_k w_l (power
    window, normalised), binned: (d_s [m], W [m])."""
    n = len(window)
    k = np.linspace(0, n - 1, n_points).astype(int)
    w = window[k] ** 2
    w = w / w.sum()
    u = (k - n / 2) / prf_hz
    d = (u[:, None] - u[None, :]).ravel()
    W = (w[:, None] * w[None, :]).ravel()
    edges = np.linspace(d.min() - 1e-12, d.max() + 1e-12, 2 * n_points)
    idx = np.digitize(d, edges)
    bins = [i for i in np.unique(idx) if W[idx == i].sum() > 0]
    ds = np.array([np.average(d[idx == i], weights=W[idx == i]) for i in bins])
    Ws = np.array([W[idx == i].sum() for i in bins])
    return ds, Ws


#: correlation shapes: name -> (rho(x), x at which rho = 1/e); Matern 1/2 (exponential,
#: an Ornstein-Uhlenbeck or telegraph process) and Matern 3/2 (a smooth process, e.g.
#: two cascaded first-order filters)
SHAPES = {"exponential": (lambda x: np.exp(-x), 1.0), "matern32": (lambda x: (1 + x) * np.exp(-x), 2.1462)}


def model_cov_db2(
    lags_s: np.ndarray, sigma_db, tau_s, ds: np.ndarray, W: np.ndarray, shape: str = "exponential"
) -> np.ndarray:
    """c(L) [dB^2] of the window-averaged gain (module doc) with 1/e correlation time
    ``tau_s`` and correlation ``shape`` (:data:`SHAPES`); broadcasting over
    ``sigma_db`` and ``tau_s`` (leading axes) and ``lags_s`` (last axis)."""
    s = np.asarray(sigma_db, float)[..., None, None]
    T = np.asarray(tau_s, float)[..., None, None]
    L = np.asarray(lags_s, float)[:, None]
    rho_f, x1e = SHAPES[shape]
    rho = rho_f(np.abs(L + ds[None, :]) * x1e / T)
    k = np.expm1(B * B * s * s * rho)
    return np.log1p((k * W).sum(-1)) / (B * B)


def variogram(y: np.ndarray, valid: np.ndarray, lags: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sample variogram of ``y`` [n] at integer ``lags`` over pairs of valid samples:
    (gamma [len(lags)], number of pairs)."""
    g, npair = [], []
    for L in lags:
        m = valid[:-L] & valid[L:]
        d = (y[L:] - y[:-L])[m]
        g.append(0.5 * float(np.mean(d * d)) if len(d) else np.nan)
        npair.append(int(len(d)))
    return np.array(g), np.array(npair)


def _lag_grid(n: int, hop_s: float, max_lag_s: float) -> np.ndarray:
    """Lags [hops] of the variogram: 1, 2, 3, 4, then ~geometric up to ``max_lag_s``
    (and at most a third of the record)."""
    lag_max = int(max(1, min(max_lag_s / hop_s, n // 3)))
    cand = np.unique(np.round(np.concatenate([np.arange(1, 5), np.geomspace(4, max(lag_max, 4), 16)])).astype(int))
    return cand[cand <= lag_max]


def harmonic_speed_slope(Y: np.ndarray, V: np.ndarray, harm: np.ndarray, u: np.ndarray) -> float:
    """Slope beta [dB per harmonic number per unit of ``u``] of the per-harmonic dB
    series ``Y`` [n, K] on the rotor-speed deviation ``u`` [n], under the paper's
    envelope exp(-alpha |f|): harmonic n's sideband power moves by n beta u (beta =
    -20 log10(e) alpha B for u in rev/s), so a speed change tilts the harmonics
    against each other.

    Fitted by least squares on the deviations from each sample's mean over its
    valid harmonics (``V`` [n, K]; samples with >= 2): a gain common to all the
    harmonics (a fading) cancels there exactly, so beta is not biased by a chance
    correlation of the fading with the speed. Returns 0 when nothing identifies it
    (fewer than two harmonics at every sample, or a speed that does not change).
    """
    Y = np.asarray(Y, float)
    V = np.asarray(V, bool)
    Kt = V.sum(axis=1)
    rows = Kt >= 2
    if not rows.any():
        return 0.0
    Yv = np.where(V, Y, 0.0)
    mY = Yv.sum(axis=1) / np.maximum(Kt, 1)
    mn = (V * np.asarray(harm, float)[None, :]).sum(axis=1) / np.maximum(Kt, 1)
    D = Y - mY[:, None]
    G = (np.asarray(harm, float)[None, :] - mn[:, None]) * np.asarray(u, float)[:, None]
    W = V & rows[:, None]
    den = float(np.sum(G[W] ** 2))
    # a speed that does not change (rms below 1e-6 of a unit) identifies nothing
    return float(np.sum(D[W] * G[W]) / den) if den > 1e-12 * max(int(W.sum()), 1) else 0.0


def fit_gain_process(
    y: np.ndarray,
    valid: np.ndarray,
    noise_var_db2: np.ndarray,
    hop_s: float,
    window: np.ndarray,
    prf_hz: float,
    *,
    max_lag_s: float = 10.0,
    tau_bounds_s: tuple = (0.01, 30.0),
    min_pairs: int = 20,
    drift: bool = True,
    noise_free: bool = False,
) -> dict:
    """Joint (sigma [dB], T [s]) of the gain seen in the series ``y`` [dB] on a grid
    of hops ``hop_s`` (module doc).

    Parameters
    ----------
    y : ndarray [n]
        dB power per window (any offset; detrended or not).
    valid : bool ndarray [n]
    noise_var_db2 : ndarray [n]
        Measurement-noise variance of each sample [dB^2].
    hop_s : float
        Spacing of the windows [s].
    window : ndarray
        The analysis window (its power profile is the averaging kernel).
    prf_hz : float
        Sample rate of the window's points [Hz].
    noise_free : bool
        Fit the noise level in [0, the given one] (grid of 5) instead of fixing it:
        for a noise estimated from a scatter that may be partly slow (then not white).
    drift : bool
        Add a nuisance term kappa * L to the variogram (kappa >= 0 [dB^2/s], fitted):
        slow variations (aspect, range-cell straddle) far slower than the lags, whose
        variogram grows about linearly there.

    Returns
    -------
    dict
        ``sigma_db``, ``timescale_s``, the lags [s] and the measured and fitted
        variograms [dB^2], ``noise_db2`` (mean noise variance).
    """
    lags = _lag_grid(len(y), hop_s, max_lag_s)
    g, npair = variogram(y, valid, lags)
    nv = float(np.mean(noise_var_db2[valid])) if valid.any() else 0.0
    return fit_variogram(
        lags,
        g,
        npair,
        nv,
        hop_s,
        window,
        prf_hz,
        tau_bounds_s=tau_bounds_s,
        min_pairs=min_pairs,
        drift=drift,
        noise_free=noise_free,
    )


def fit_variogram(
    lags: np.ndarray,
    g: np.ndarray,
    npair: np.ndarray,
    nv: float,
    hop_s: float,
    window: np.ndarray,
    prf_hz: float,
    *,
    tau_bounds_s: tuple = (0.01, 30.0),
    min_pairs: int = 20,
    drift: bool = True,
    noise_free: bool = False,
) -> dict:
    """Fit (sigma [dB], T [s]) (and the nuisance drift) to a measured variogram ``g``
    [dB^2] at integer ``lags`` [hops] with ``npair`` pairs each, noise variance ``nv``
    [dB^2] (see :func:`fit_gain_process` for the other arguments and the result)."""
    ok = np.isfinite(g) & (npair >= min_pairs) & (g > 0)
    lags, g = lags[ok], g[ok]
    out = {
        "sigma_db": 0.0,
        "timescale_s": float("nan"),
        "lags_s": (lags * hop_s).tolist(),
        "variogram_db2": g.tolist(),
        "noise_db2": nv,
    }
    if len(lags) < 3:
        return out
    ds, W = window_offsets(window, prf_hz)
    # T beyond max_lag / 2.5 leaves the variogram's sill unseen (sigma and T trade off)
    t_hi = min(tau_bounds_s[1], lags[-1] * hop_s / 2.5)
    taus = TAU_GRID_S[(TAU_GRID_S >= tau_bounds_s[0]) & (TAU_GRID_S <= t_hi)]
    sig = np.concatenate([[0.0], np.geomspace(0.1, 20.0, 120)])
    kap = np.concatenate([[0.0], np.geomspace(0.01, 10.0, 25)]) if drift else np.zeros(1)
    nug = nv * (np.linspace(0.0, 1.0, 5) if noise_free else np.ones(1))
    Ls = lags * hop_s
    lg = np.log(g)

    def best(sv, tv, shape):
        C = model_cov_db2(np.concatenate([[0.0], Ls]), sv[:, None], tv[None, :], ds, W, shape)  # [n_sig, n_tau, 1+n]
        gm = (
            (C[..., :1] - C[..., 1:])[:, :, None, None, :]
            + kap[None, None, :, None, None] * Ls
            + nug[None, None, None, :, None]
        )
        cost = np.sum((lg - np.log(np.maximum(gm, 1e-9))) ** 2, axis=-1)
        i, j, k, q = np.unravel_index(int(np.argmin(cost)), cost.shape)
        return float(cost[i, j, k, q]), i, j, k, gm[i, j, k, q]

    results = []
    for shape in SHAPES:
        c0, i, j, k, fit = best(sig, taus, shape)
        s_best, t_best, k_best = float(sig[i]), float(taus[j]), float(kap[k])
        if 0 < i < len(sig) - 1:  # finer around the best (the sigma grid step is 4.5 %)
            sf = np.linspace(sig[i - 1], sig[i + 1], 21)
            tf = np.geomspace(taus[max(j - 1, 0)], taus[min(j + 1, len(taus) - 1)], 11)
            c0, a, b, k, fit = best(sf, tf, shape)
            s_best, t_best, k_best = float(sf[a]), float(tf[b]), float(kap[k])
        results.append((c0, shape, s_best, t_best, k_best, fit))
    cost_best, shape_best, s_best, t_best, k_best, fit = min(results, key=lambda r: r[0])
    out["shape"] = shape_best
    out.update(
        {
            "sigma_db": s_best,
            "timescale_s": t_best if s_best > 0 else float("nan"),
            "drift_db2_per_s": k_best,
            "variogram_fit_db2": np.asarray(fit).tolist(),
        }
    )
    return out


def fit_gain_process_ml(
    y: np.ndarray,
    valid: np.ndarray,
    noise_var_db2: np.ndarray,
    hop_s: float,
    window: np.ndarray,
    prf_hz: float,
    start: tuple,
    *,
    block: int = 512,
    tau_bounds_s: tuple = (0.01, 30.0),
    design: np.ndarray | None = None,
    free_white: bool = False,
) -> dict:
    """Joint (sigma [dB], T [s]) of the gain in the series ``y`` [dB] (mean zero,
    e.g. detrended) by its exact Gaussian likelihood: covariance c(L) of the
    window-averaged exponentially correlated gain (:func:`model_cov_db2`, window
    ``window`` at ``prf_hz``, samples ``hop_s`` apart) plus the measurement noise
    ``noise_var_db2`` [n] of each valid sample (white); samples off ``valid`` are
    left out of the covariance. Maximised by Nelder-Mead in (log sigma, log T) from
    ``start`` = (sigma, T) (e.g. :func:`fit_gain_process`'s).

    With ``design`` [n, p] (the regressors a trend was fitted on and taken out of
    ``y``, e.g. 1, t, log range) the likelihood is the restricted one (REML): the
    part of the gain the trend took out is not read as missing variance, which on
    a record of a few tens of T biases sigma low (a 40 s flight with T = 2.5 s:
    sigma 38 % low without it).

    With ``free_white`` a third parameter, a white variance w [dB^2] added to every
    sample's ``noise_var_db2``, is fitted with them (returned as ``extra_white_db2``):
    for a nuisance whose size is only partly known (the part of the rotors' beats that
    is common to the harmonics).

    The series is cut into consecutive stretches of ``block`` samples whose
    likelihoods are summed (cost linear in the record; the correlation across a
    cut, over a few T, is a small loss for stretches of hundreds of T/hop).

    Weighs every lag by its information where the variogram fit weighs the lags
    alike: on a grid much finer than T (short windows) the short lags carry most of
    the information on T. Needs the noise right: a nuisance that is not white on the
    grid is read as part of the gain. Returns a dict ``sigma_db``, ``timescale_s``,
    ``nll``, ``n_eval``.
    """
    from scipy.linalg import cho_factor, cho_solve
    from scipy.optimize import minimize

    y = np.asarray(y, float)
    idx = np.flatnonzero(np.asarray(valid, bool))
    out = {
        "sigma_db": float(start[0]),
        "timescale_s": float(start[1]),
        "nll": float("nan"),
        "n_eval": 0,
        "extra_white_db2": 0.0,
    }
    if len(idx) < 20 or not (start[0] > 0 and np.isfinite(start[1]) and start[1] > 0):
        return out
    ds, W = window_offsets(window, prf_hz)
    nv = np.asarray(noise_var_db2, float)
    blocks = [idx[(idx >= a) & (idx < a + block)] for a in range(idx[0], idx[-1] + 1, block)]
    blocks = [b for b in blocks if len(b) >= 2]
    n_lag = max(int(b[-1] - b[0]) + 1 for b in blocks)
    lag_idx = [np.abs(b[:, None] - b[None, :]) for b in blocks]
    lo, hi = np.log(tau_bounds_s[0]), np.log(tau_bounds_s[1])
    X = None if design is None else np.asarray(design, float)
    if X is not None:  # drop regressors that add nothing (e.g. a constant range)
        Rd = np.abs(np.diag(np.linalg.qr(X[idx], mode="r")))
        X = X[:, Rd > 1e-8 * max(float(Rd.max()), 1e-300)]

    def nll(p):
        ls, lt = p[:2]
        lw = p[2] if free_white else -np.inf
        if not (lo <= lt <= hi) or not (-3.0 <= ls <= 3.0) or lw > 5.0:
            return 1e12
        cl = model_cov_db2(np.arange(n_lag) * hop_s, np.exp(ls), np.exp(lt), ds, W)
        tot = 0.0
        A = g = None
        for b, L in zip(blocks, lag_idx):
            C = cl[L]
            C[np.diag_indices_from(C)] += nv[b] + np.exp(lw)
            try:
                cf = cho_factor(C, lower=True, check_finite=False)
            except np.linalg.LinAlgError:
                return 1e12
            yb = y[b]
            tot += float(np.sum(np.log(np.diag(cf[0]))) + 0.5 * yb @ cho_solve(cf, yb, check_finite=False))
            if X is not None:
                CiX = cho_solve(cf, X[b], check_finite=False)
                A = X[b].T @ CiX if A is None else A + X[b].T @ CiX
                g = CiX.T @ yb if g is None else g + CiX.T @ yb
        if X is not None:
            sgn, logdet = np.linalg.slogdet(A)
            if sgn <= 0:
                return 1e12
            tot += 0.5 * logdet - 0.5 * float(g @ np.linalg.solve(A, g))
        return tot

    x0 = np.log([start[0], start[1]])
    if free_white:  # from a small extra white, a tenth of the known noise (at least 0.01 dB^2)
        x0 = np.r_[x0, np.log(max(0.1 * float(np.mean(nv[idx])), 0.01))]
    r = minimize(
        nll,
        x0,
        method="Nelder-Mead",
        options={"xatol": 0.005, "fatol": 0.01, "maxiter": 300 if not free_white else 600},
    )
    if np.isfinite(r.fun) and r.fun < 1e11:
        out.update(
            {
                "sigma_db": float(np.exp(r.x[0])),
                "timescale_s": float(np.exp(r.x[1])),
                "nll": float(r.fun),
                "n_eval": int(r.nfev),
                "extra_white_db2": float(np.exp(r.x[2])) if free_white else 0.0,
            }
        )
    return out
