"""``sideband_fading``: blade (sideband) power fluctuating over seconds independently
of the body.

- catalog: ``fading_std_db`` [dB], ``timescale_s`` [s];
- test (:func:`test_fading`): common-mode (random-effects) test on the mean
  sideband-pair power over the harmonics, with the paper's envelope's tilt by the
  rotor speed taken out (:func:`speed_tilt`); size and correlation time jointly
  (:func:`fading_estimate`, :func:`fading_estimate_fine`); re-read with a named floor
  partner in the floor's model (``reads_sidebands``, a pair's clear side);
- twins: ``blade_hook`` multiplies the blade signal by 10^(x(t)/20), x an
  Ornstein-Uhlenbeck process in dB;
- emulator: the blade signal is multiplied by such a gain (drawn after the blades'
  natural variation).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..synthesis.processes import GainHook, SlowGain
from .base import CauseSpec, Param, draw_band_panel
from .heldout import (
    CauseTest,
    _crossfit,
    _detrend,
    _gauss_ll,
    _lag_grid,
    _ml_extra_var,
    fit_gain_process,
    fit_gain_process_ml,
    fit_variogram,
    harmonic_speed_slope,
)
from .measure import DB

NAME = "sideband_fading"
#: sub-seed of the twins' fading process (independent streams from one seed)
STREAM = 1
#: default of the fading correlation time [s] when not given
DEFAULT_FADING_TIMESCALE_S = 1.5


def common_gain_correlation(M, e: np.ndarray, m: np.ndarray) -> tuple[float, float] | None:
    """Correlation of the detrended common sideband power ``e`` (the fading test's
    series, on CPIs ``m``) with the detrended body power [dB] on the same CPIs, and
    the ratio of their standard deviations (body over sidebands); None when the body
    line is not measurable (in the clutter notch) or too few CPIs hold it."""
    body_pow = getattr(M, "body_pow", None)
    if body_pow is None or M.info.get("body_in_notch"):
        return None
    ok = body_pow[m] > 0
    if ok.sum() < 8:
        return None
    y = DB * np.log(np.maximum(body_pow[m][ok], 1e-30))
    yb = _detrend(y, M.t_s[m][ok], M.range_m[m][ok])
    x = e[ok]
    if np.std(x) <= 0 or np.std(yb) <= 0:
        return None
    return float(np.corrcoef(x, yb)[0, 1]), float(np.std(yb) / np.std(x))


def test_fading(M, cfg, fold) -> CauseTest:
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
    res = CauseTest(NAME, statistic="mean sideband-pair power [dB], common to all harmonics")
    use = M.usable_pair_sums
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
    dev = np.where(ok, x, np.nan)[m] - c[:, None]
    Km = K[m].astype(float)
    ss = np.nansum(dev**2, axis=1)
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
        v0 = sw2(sel) / Km[sel] + cfg.model_floor_db**2
        return sw2(sel), _ml_extra_var(e[sel], v0)

    def score(th, sel):
        s2w, s2 = th
        v0 = s2w / Km[sel] + cfg.model_floor_db**2
        return _gauss_ll(e[sel], 0.0, v0), _gauss_ll(e[sel], 0.0, v0 + s2)

    _crossfit(f, fit, score, res)
    res.held_out = res.held_out and not borrowed
    s2w, s2 = fit(np.ones(len(e), bool))
    v0 = s2w / Km + cfg.model_floor_db**2
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
    cg = common_gain_correlation(M, e, m)
    body_corr, body_share = cg if cg is not None else (None, None)
    if (
        body_corr is not None
        and body_corr > cfg.common_gain_corr
        and body_share >= cfg.common_gain_body_share
        and cpi_sd >= cfg.margin_common_gain_db
        and cpi_sd > 0
    ):
        # the sidebands follow the body, and the body moves as much: one gain on the
        # whole target (a range-cell straddle, an aspect change), not a blade fading
        # (its own margin: no catalog cause is named for it)
        res.relevant = False
        res.evidence["common_gain_db"] = round(cpi_sd, 2)
        res.evidence["reason"] = (
            f"the common sideband power follows the body's (correlation {body_corr:.2f} > "
            f"{cfg.common_gain_corr}, the body moving {body_share:.2f} as many dB): a gain on "
            f"the whole target, not a fading of the blades"
        )
    res.series = {"t_s": M.t_s[m], "stat": e, "base": np.sqrt(v0), "ext": np.sqrt(v0 + s2)}
    res.evidence = {
        **res.evidence,
        "fading_std_db": round(true_sd, 2),
        "timescale_s": round(tau, 2),
        "body_correlation": None if body_corr is None else round(body_corr, 3),
        "body_share": None if body_share is None else round(body_share, 3),
        "variogram_lags_s": [round(x, 3) for x in est["lags_s"]],
        "variogram_db2": [round(x, 3) for x in est["variogram_db2"]],
        "speed_tilt_db_per_harmonic_rev_s": round(est["speed_tilt_db"], 4),
        "measured_common_std_db": round(meas_sd, 2),
        "within_cpi_harmonic_std_db": round(float(np.sqrt(s2w)), 2),
        "n_pairs_used": int(use.sum()),
        "estimate_grid": "short windows" if fine is not None else "CPI",
        "cpi_grid_fading_std_db": round(cpi_sd, 2),
        "cpi_grid_timescale_s": round(float(est["timescale_s"]), 2),
    }
    return res


def _speed_tilt_fit(M, x, ok, m):
    """(beta, u [n_t], Y [n_t, N], V [n_t, N]): each harmonic's series ``x`` [dB]
    detrended in time and log range (Y, valid where V), the motor log's mean speed
    likewise (u [rev/s], 0 off ``m``), and the slope beta of Y on n u
    (:func:`harmonic_speed_slope`)."""
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
    ``measure.calibrate`` but on the pairs' summed power (the harmonics ``use``): the
    slope of each harmonic's median measured / model power [dB] (the model without
    envelope, so the wire's own roll-off is out) over its frequency n B f (f the
    median logged speed), clipped to a decaying envelope (beta <= 0). A fading is
    common to all the harmonics and leaves the medians' slope alone.

    Not fitted to the fluctuations: on flights whose sidebands end after one or two
    pairs, the slope of the harmonics' deviations from their CPI mean on the speed
    (:func:`harmonic_speed_slope`) rests on the few CPIs where two pairs
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
    (:func:`fit_gain_process` on the CPI grid: analytic CPI-window
    averaging), from the harmonics' sideband-pair powers ``x`` [dB, n_t x N] (valid
    where ``ok``, CPIs ``m``).

    Each harmonic's series is detrended linearly in time and log range. Then the
    rotor-speed tilt is taken out: under the paper's envelope exp(-alpha |f|) a
    change u of the mean rotor speed (the motor log's, CPI-averaged) moves harmonic
    n's power by n beta u dB; beta is the given one (``test_fading`` passes the
    calibrated envelope's, :func:`envelope_tilt`, on ``x`` with the tilt already
    out: ``beta=0``), else fitted on the harmonics' deviations from their CPI mean,
    where a common gain cancels (:func:`harmonic_speed_slope`).
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
    est = fit_gain_process(
        yy, mm.copy(), nv, float(np.median(np.diff(t))), M.stft.window, M.info["prf_hz"], drift=False, noise_free=True
    )
    est["speed_tilt_db"] = beta
    return est


def fading_estimate_fine(
    M, ok, m, beta: float, u: np.ndarray, *, min_windows: int = 200, max_lag_s: float = 10.0
) -> dict | None:
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
    (:func:`fit_gain_process_ml`: window-averaged exponential
    correlation plus the white nuisance n / K and a free white variance w, the part of
    the beats common to the harmonics, which their differences do not see: with w
    left out, an OU fading under four rotors 1-3 % apart came out ~16 % short;
    restricted to the residual of the
    trend in time and log range; T up to the longest lag / 2.5; where it still
    rises there, the variogram's estimate is kept), started from the variogram fit
    with the nuisance subtracted lag by lag (gamma(L) = mean[d^2 / 2] - n(L)
    mean[1 / K], :func:`fit_variogram`, no nugget, no drift). How it was tuned:
    ``docs/experiments.md`` ("Fading timescale on short windows")."""
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
            g.append(np.nan)
            npair.append(0)
            continue
        d = D.sum(1) / np.maximum(K, 1)
        dd = np.where(Vc, D - d[:, None], 0.0)
        nh[int(L)] = 0.5 * float(np.mean((dd[s2] ** 2).sum(1) / (K[s2] - 1)))
        g.append(0.5 * float(np.mean(d[s1] ** 2)) - nh[int(L)] * float(np.mean(1.0 / K[s1])))
        npair.append(int(s1.sum()))
    est = fit_variogram(lags, np.array(g), np.array(npair), 0.0, F["hop_s"], F["window"], M.info["prf_hz"], drift=False)
    short = [nh[L] for L in (1, 2, 3, 4) if L in nh]
    if not (est["sigma_db"] > 0 and np.isfinite(est["timescale_s"])) or not short:
        return None
    n_h = float(np.mean(short))
    c = np.zeros(len(t))
    c[use] = _detrend(np.where(V, Y, 0.0).sum(1)[use] / Kt[use], t[use], r[use])
    # T searched up to the longest lag / 2.5, as the variogram fit (beyond, sigma and T trade off)
    t_hi = min(30.0, float(lags[-1]) * F["hop_s"] / 2.5)
    ml = fit_gain_process_ml(
        c,
        use,
        np.where(use, n_h / np.maximum(Kt, 1), 0.0),
        F["hop_s"],
        F["window"],
        M.info["prf_hz"],
        (est["sigma_db"], est["timescale_s"]),
        tau_bounds_s=(0.01, t_hi),
        design=np.column_stack([np.ones(len(t)), t - t[use].mean(), np.log10(r / r[use].mean())]),
        free_white=True,
    )
    est["variogram_sigma_db"], est["variogram_timescale_s"] = est["sigma_db"], est["timescale_s"]
    # a likelihood still rising at the longest T searched has not seen the sill (a
    # record of a few tens of T): the variogram's estimate is kept there
    if ml["n_eval"] > 0 and ml["timescale_s"] < 0.98 * t_hi:
        est["sigma_db"], est["timescale_s"] = ml["sigma_db"], ml["timescale_s"]
    est["nuisance_db2_per_harmonic"] = n_h
    est["common_white_db2"] = float(ml.get("extra_white_db2", 0.0))
    est["n_windows"] = int(use.sum())
    return est


class SidebandFading(CauseSpec):
    name = NAME
    meaning = "blade (sideband) power fluctuates over seconds independently of the body"
    params = (
        Param(
            "fading_std_db",
            "dB",
            "standard deviation over time of the blade power gain in dB (log-normal gain, Ornstein-Uhlenbeck in dB)",
            ">= 3",
        ),
        Param("timescale_s", "s", "correlation time of the fading", "1-2 s"),
    )
    observations = (
        "up",
        "lo",
        "pair_ok",
        "usable_pair_sums",
        "valid",
        "harm",
        "t_s",
        "range_m",
        "f_log_hz",
        "dil",
        "dil_ok",
        "model_h",
        "body_pow",
        "side_fine",
        "stft",
        "info",
    )
    line = "rotor"
    reads_sidebands = True
    clear_side = True
    margin_field = "margin_std_db"
    defaults = {"timescale_s": DEFAULT_FADING_TIMESCALE_S}
    bounds = (("fading_std_db", ">= 0"), ("timescale_s", "> 0"))
    world_defaults = {"timescale_s": 1.5}

    def test(self, M, cfg, fold, given=frozenset()):
        return test_fading(M, cfg, fold)

    def model_extension(self, p, *, duration_s, seed):
        rng = np.random.default_rng([int(seed), STREAM])
        return {"blade_hook": GainHook(duration_s, p["fading_std_db"], p["timescale_s"], rng)}

    def world_check(self, full):
        if not (full["fading_std_db"] >= 0 and full["timescale_s"] > 0):
            raise ValueError(
                f"{NAME}: fading_std_db={full['fading_std_db']} must be >= 0 and timescale_s={full['timescale_s']} > 0"
            )

    def world_blade_gain(self, p, duration_s, rng):
        return SlowGain(duration_s, p["fading_std_db"], p["timescale_s"], rng)

    def draw_panel(self, ax, test):
        draw_band_panel(ax, test)


CAUSE = SidebandFading()
