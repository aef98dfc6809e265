"""Step 2 of the diagnosis: one held-out likelihood test per catalog cause.

:func:`run_tests` reads the flight's :class:`~.measure.Measurements` only (never the
I/Q or a spectrogram) and returns every cause's :class:`CauseTest` against the
paper's model, and the tests of the causes whose statistics depend on each other
(:data:`COUPLED`) with the other one in both models, for :mod:`.decide`.

Every cause is tested the same way. The CPIs are cut into alternating blocks of
``block_cpis`` (folds A and B). On each fold the paper's model (baseline) and the
model extended by the cause are fitted, and both are scored on the *other* fold by
the log-likelihood of the cause's statistic. The two held-out likelihood ratios are
averaged: under the baseline the average has expectation <= 1 whatever was fitted
(each ratio is a likelihood ratio on data its fit did not see), so it is an e-value
and P(ratio >= 1/a) <= a (Markov). A cause is *significant* when its log e-value
exceeds the threshold of its greedy step (``decide.step_threshold``: Bonferroni over the
causes at level alpha / (k (k + 1)) at step k) and *relevant* when its fitted effect
is at least a margin (a fraction of the catalog's detectable size). ``decide.decide_all``
names causes greedily, strongest first, each later step testing the remaining causes
with the named causes' extensions in both models (``given`` of :func:`test_log`; the
other statistics are unchanged by another cause's extension, see :data:`COUPLED`).

Sizes and correlation times of the fluctuating causes are estimated jointly and
analytically (:func:`fit_gain_process`, :func:`fit_gain_process_ml`: variogram and
exact likelihood of the per-window dB series, window averaging and noise accounted
for), without simulating any process: the body's on
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

The fixed settings read here are :mod:`.config`'s constants.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np
from scipy.optimize import minimize_scalar

from ..synthesis.catalog import PHASE_NOISE_BANDWIDTH_HZ, SKIRT_OFFSET_HZ
from .config import (BODY_SMOOTH_CPIS, LAG_STEP_S, MIN_PAIR_SNR, PN_BODY_SKIRT_HZ, PN_CLUTTER_DECAYS_HZ,
                     PN_PROFILE_AGREE_DB, PN_PROFILE_BODY_GUARD_HZ, PN_PROFILE_FALL_DB,
                     DiagnosisConfig)
from .measure import (DB, Measurements, Undiagnosable, given_imbalance, given_skirt, ordinate_subset,
                      robust_skirt_levels, skirt_ordinates, skirt_power, skirt_profile, skirt_shape)

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
    fit: dict = field(default_factory=dict)      # fitted model other tests condition on (phase noise: its skirt)


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

def test_asymmetry(M, cfg, fold) -> CauseTest:
    use = M.usable_pairs
    ok = M.pair_ok & use[None, :]
    U = np.where(ok, M.up, 0).sum(1)
    L = np.where(ok, M.lo, 0).sum(1)
    m = M.valid & (U > 0) & (L > 0)
    res = CauseTest("sideband_asymmetry", statistic="upper/lower sideband power [dB]")
    if m.sum() < 2 * cfg.block_cpis:
        res.testable = False
        res.evidence = {"reason": f"usable sideband pairs (median >= {MIN_PAIR_SNR:g} dB over the floor) "
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


def imbalance_from_ratio(r: float, n_blades: int) -> float:
    """``imbalance_db`` of one blade of amplitude a (the others 1) whose lines at the
    non-multiples of the blade count stand r below the blade-passing lines.

    Rotation harmonic k of the rotor is the single blade's, c_k, times
    sum_b a_b exp(j 2 pi k b / B): B - 1 + a for k a multiple of B, a - 1 otherwise,
    so r = ((1 - a) / (B - 1 + a))^2 and a = (1 - (B - 1) q) / (1 + q), q = sqrt(r).
    Returns -20 log10(a) [dB] (0 for r <= 0); NaN when r >= 1 / (B - 1)^2, more than
    one blade alone can make (a <= 0)."""
    if not np.isfinite(r) or r <= 0:
        return 0.0
    q = float(np.sqrt(r))
    a = (1 - (n_blades - 1) * q) / (1 + q)
    return float(-20 * np.log10(a)) if a > 0 else float("nan")


def imbalance_observations(M):
    """The blade-imbalance test's observations, one per (CPI, non-multiple order k,
    side): the measured power ``x`` of the rotors' lines of order k, its noise variance
    ``v0`` and variance per unit line power ``w``, and the reference ``ref``: the
    blade-passing lines on both sides of k (geometric mean), each divided by one thin
    wire's line power and the pair multiplied by order k's (:func:`.measure.thin_wire_line_power`),
    so the envelope exp(-alpha |f|) and the wire's own line powers cancel, scaled by
    the share of rotors whose line of order k is clear. Returns flat arrays and each
    observation's CPI index (:func:`non_multiple_observations` of ``M``'s rotation lines)."""
    return non_multiple_observations(M.rot_pow, M.rot_var, M.rot_cross, M.rot_n, M.rot_wire,
                                     M.info["n_blades"], M.log.n_motors)


def non_multiple_observations(P, V, W, R, c2, n_blades: int, n_motors: int, *, min_z: float = 0.0):
    """:func:`imbalance_observations` from the arrays of
    :func:`.measure.rotation_line_powers` (``P``, ``V``, ``W``, ``R``: [n_t, K, 2]) and one
    wire's line powers ``c2`` [K + 1]; with ``min_z`` > 0 only where both blade-passing
    lines stand ``min_z`` noise standard deviations above the floor."""
    B = int(n_blades)
    out = [[], [], [], [], []]
    for k in range(1, P.shape[1] + 1):
        n1 = (k // B) * B
        n2 = n1 + B
        if k % B == 0 or n1 < 1 or n2 > P.shape[1]:
            continue
        for s in (0, 1):
            a, b = P[:, n1 - 1, s], P[:, n2 - 1, s]
            with np.errstate(invalid="ignore", divide="ignore"):
                ref = (np.sqrt(np.clip(a, 0, None) * np.clip(b, 0, None)) * c2[k] / np.sqrt(c2[n1] * c2[n2])
                       * R[:, k - 1, s] / n_motors)
                seen = (a > min_z * np.sqrt(V[:, n1 - 1, s])) & (b > min_z * np.sqrt(V[:, n2 - 1, s]))
            x = P[:, k - 1, s]
            ok = (np.isfinite(x) & np.isfinite(ref) & (ref > 0) & (R[:, n1 - 1, s] == n_motors)
                  & (R[:, n2 - 1, s] == n_motors) & seen)
            i = np.flatnonzero(ok)
            for lst, arr in zip(out, (x[i], V[i, k - 1, s], W[i, k - 1, s], ref[i], i)):
                lst.append(arr)
    x, v0, w, ref, idx = (np.concatenate(z) if z else np.zeros(0) for z in out)
    return x, v0, w, ref, idx.astype(int)


def test_imbalance(M, cfg, fold) -> CauseTest:
    """Lines at non-multiples of the blade count (:func:`imbalance_observations`),
    relative to the blade-passing lines beside them: eq. (1)'s identical blades make
    none (base: mean 0), a weak or strong blade makes them r below (extended: mean r;
    :func:`imbalance_from_ratio` turns r into ``imbalance_db``). Both models carry the
    noise variance and an extra variance fitted on the training fold (ML); r is the
    training fold's median ratio."""
    res = CauseTest("blade_imbalance", statistic="non-multiple / blade-passing line power")
    B = M.info["n_blades"]
    if M.rot_pow is None:
        res.testable = False
        res.evidence = {"reason": "rotation harmonics not measured"}
        return res
    x, v0, w, ref, idx = imbalance_observations(M)
    f = fold[idx] if len(idx) else np.zeros(0, int)
    n_cpi = len(np.unique(idx))
    if n_cpi < cfg.block_cpis or len(np.unique(f)) < 2:
        res.testable = False
        res.evidence = {"reason": f"blade-passing lines on both sides of a non-multiple order, clear of "
                                  f"other lines, in {n_cpi} CPIs (expected >= {cfg.block_cpis}, two folds)"}
        return res
    z = x / ref
    vz0 = v0 / ref ** 2
    wz = w / ref

    def fit(sel):
        r = max(float(np.median(z[sel])), 0.0)
        vb = _ml_extra_var(z[sel], vz0[sel])
        ve = _ml_extra_var(z[sel] - r, vz0[sel] + wz[sel] * r)
        return r, vb, ve

    def score(th, sel):
        r, vb, ve = th
        return (_gauss_ll(z[sel], 0.0, vz0[sel] + vb + 1e-12),
                _gauss_ll(z[sel], r, vz0[sel] + wz[sel] * r + ve + 1e-12))

    _crossfit(f, fit, score, res)
    r = max(float(np.median(z)), 0.0)
    imb = imbalance_from_ratio(r, B)
    res.params = {"imbalance_db": imb if np.isfinite(imb) else float("nan")}
    res.effect = imb if np.isfinite(imb) else 0.0
    res.relevant = bool(np.isfinite(imb) and imb >= cfg.margin_imbalance_db)
    res.evidence = {"ratio_db": round(float(DB * np.log(max(r, 1e-12))), 2), "n_blades": int(B),
                    "n_cpis": int(n_cpi), "n_lines": int(len(z))}
    if not np.isfinite(imb):
        res.evidence["reason"] = (f"the non-multiple lines stand {DB * np.log(r):.1f} dB from the blade-passing "
                                  "lines: more than one weak or strong blade can make, not an imbalance")
    cpi_r = np.array([np.median(z[idx == i]) for i in np.unique(idx)])
    res.series = {"t_s": M.t_s[np.unique(idx)], "stat": DB * np.log(np.clip(cpi_r, 1e-6, None)),
                  "base": np.full(n_cpi, -60.0), "ext": np.full(n_cpi, DB * np.log(max(r, 1e-6)))}
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


#: a common sideband gain that correlates this much with the body power, and moves
#: the body by at least :data:`COMMON_GAIN_BODY_SHARE` as many dB, is the whole
#: target's (range-cell straddle, aspect), not a blade fading (the catalog's fading is
#: independent of the body; the independent generator's fading flights read |r| < 0.3)
COMMON_GAIN_CORR = 0.7
#: the body's dB excursions over the sidebands' (std ratio) that a gain on the whole
#: target gives: it moves both alike (ratio ~1, the sidebands' noise lowering it). A
#: blade fading moves the body line only by the blades' share in it (their mean return
#: lies on the body Doppler), well under 0.5 even where it correlates strongly.
COMMON_GAIN_BODY_SHARE = 0.5


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
    res = CauseTest("sideband_fading", statistic="mean sideband-pair power [dB], common to all harmonics")
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
    cg = common_gain_correlation(M, e, m)
    body_corr, body_share = cg if cg is not None else (None, None)
    if (body_corr is not None and body_corr > COMMON_GAIN_CORR and body_share >= COMMON_GAIN_BODY_SHARE
            and cpi_sd >= cfg.margin_common_gain_db and cpi_sd > 0):
        # the sidebands follow the body, and the body moves as much: one gain on the
        # whole target (a range-cell straddle, an aspect change), not a blade fading
        # (its own margin: no catalog cause is named for it)
        res.relevant = False
        res.evidence["common_gain_db"] = round(cpi_sd, 2)
        res.evidence["reason"] = (f"the common sideband power follows the body's (correlation {body_corr:.2f} > "
                                  f"{COMMON_GAIN_CORR}, the body moving {body_share:.2f} as many dB): a gain on "
                                  f"the whole target, not a fading of the blades")
    res.series = {"t_s": M.t_s[m], "stat": e, "base": np.sqrt(v0), "ext": np.sqrt(v0 + s2)}
    res.evidence = {**res.evidence, "fading_std_db": round(true_sd, 2), "timescale_s": round(tau, 2),
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
                    "cpi_grid_timescale_s": round(float(est["timescale_s"]), 2)}
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
    res, s2 = _power_fluct_test("body_fluctuation", y, M.body_sd_db, m, M, cfg, fold, smooth=BODY_SMOOTH_CPIS)
    res.statistic = "body power [dB], detrended"
    if s2 is not None:
        est = body_estimate(M) if s2 > 0 else {"sigma_db": 0.0, "timescale_s": float("nan"), "lags_s": [],
                                               "variogram_db2": []}
        sd = float(est["sigma_db"])
        tau = float(est["timescale_s"]) if sd > 0 and np.isfinite(est["timescale_s"]) else float("nan")
        res.params = {"body_std_db": sd, "timescale_s": tau}
        res.effect = sd
        res.relevant = sd >= cfg.margin_std_db
        res.evidence.update({"body_std_db": round(sd, 2), "timescale_s": round(tau, 3),
                             "variogram_lags_s": [round(x, 3) for x in est["lags_s"]],
                             "variogram_db2": [round(x, 3) for x in est["variogram_db2"]]})
    return res


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
    lags = M.lag_s
    G = M.lag_curves[:, m]
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
            lag += float(np.clip(0.5 * (a - c) / (a - 2 * b + c), -0.5, 0.5)) * LAG_STEP_S
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


def profile_skirt_test(d: dict, fold, body_spread: float = 0.0,
                       body_guard_hz: float = PN_PROFILE_BODY_GUARD_HZ) -> dict:
    """The measured skirt as a held-out test (:func:`test_phase_noise`'s second
    reading): on each fold the band levels by medians, in the bands measured on both
    sides of the clutter line (:func:`.measure.robust_skirt_levels`), scored on the other fold's ordinates by a
    Whittle likelihood against the background alone, each ordinate's power
    winsorised at ln(100) x the extended model's mean (a line among the ordinates
    then adds at most what a 1 % tail does); only ordinates at least
    ``body_guard_hz`` from the body, and the body's Lorentzian spread of weight
    ``body_spread`` (the phase-noise test's nuisance column) in the background of
    both models (a fluctuating body's spread). Returns ``{"test": CauseTest, "rise_db":
    the floor rise, by medians on the whole flight, over the ordinates of the
    innermost band measured on both sides of the clutter line, and ``fall_db``: how
    far the levels fall from that band to the outermost measured one (a skirt falls;
    a flat excess over the whole band is the target's spread, not the radar's
    skirt)}``."""
    t = CauseTest("phase_noise", statistic="held-out Whittle likelihood of the floor 35 Hz-1.2 kHz from the "
                                           "clutter line, the skirt's band levels by medians")
    # off the body's own spread: a fluctuating body beside the clutter line spreads on
    # both sides of it too; its Lorentzian tail (as the phase-noise test's model with
    # a skirt fits it) is part of the background in both models
    if body_spread > 0:
        g2 = PN_BODY_SKIRT_HZ ** 2
        line = d["A"][:, 1] / (2 * PHASE_NOISE_BANDWIDTH_HZ)  # that test's column unit: bin x body power / 2 B
        d = {**d, "S": d["S"] + body_spread * line * g2 / (d["f_rel_body_hz"] ** 2 + g2)}
    d = ordinate_subset(d, np.abs(d["f_rel_body_hz"]) >= body_guard_hz)
    F = np.asarray(fold)[d["cpi"]]
    cap = np.log(100.0)

    def score(lev, sel):
        S = d["S"][sel]
        ve = S + skirt_power(d, lev, sel)
        pc = np.minimum(d["P"][sel], cap * ve)
        return -(np.log(S) + pc / S), -(np.log(ve) + pc / ve)

    _crossfit(F, lambda sel: robust_skirt_levels(d, sel, both_sides=True), score, t)
    lev = robust_skirt_levels(d, both_sides=True)
    fin = np.flatnonzero(np.isfinite(lev))
    if not len(fin):
        return {"test": t, "rise_db": 0.0, "fall_db": 0.0}
    inner = d["jc"] == fin[0]
    ratio = (d["S"][inner] + skirt_power(d, lev, inner)) / d["S"][inner]
    with np.errstate(divide="ignore"):
        fall = float(DB * np.log(lev[fin[0]] / lev[fin[-1]])) if lev[fin[0]] > 0 else 0.0
    return {"test": t, "rise_db": float(DB * np.log(np.median(ratio))), "fall_db": fall}


def test_phase_noise(M, cfg, fold) -> CauseTest:
    """The floor near the clutter line (``M.floor_ordinates``: off the target, with
    the background recording's PSD there) by its Whittle likelihood (module doc)."""
    res = CauseTest("phase_noise", statistic="Whittle likelihood of the floor near the clutter line")
    O = M.floor_ordinates
    if O is None:
        res.testable = False
        res.evidence = {"reason": "no background/iq: the radar's own phase noise cannot be separated"}
        return res
    df = O.bin_hz
    P, S, K, F = [], [], [], []
    bw = PHASE_NOISE_BANDWIDTH_HZ
    for j, i in enumerate(O.cpi):
        fb = O.f_body_hz[j]
        fc = O.f_hz[j]
        C = float(O.clutter_pow[j])
        af = np.abs(fc)
        unit = df / (2 * bw) * C
        # columns: the phase-noise skirt (flat, |f| < 100 Hz) and nuisance shapes in both
        # models: wind-blown clutter (exponential decay from the clutter line, none by
        # default: PN_CLUTTER_DECAYS_HZ) and a skirt around the body (a fluctuating
        # body spreads its own line)
        Bt = max(float(O.body_pow[j]), 0.0) * df / (2 * bw)
        g2 = PN_BODY_SKIRT_HZ ** 2
        # the skirt: flat, and falling as (f0 / f)^2 (f0 = 50 Hz), around the clutter
        # line and the body both; a mix of the two follows a flat, a Gaussian or a
        # 1/f-like phase-noise spectrum between PN_INNER_HZ and PN_OUTER_HZ
        db_ = np.abs(fc - fb)
        flat_c, slope_c = skirt_shape(af, bw, SKIRT_OFFSET_HZ)
        flat_b, slope_b = skirt_shape(db_, bw, SKIRT_OFFSET_HZ)
        kern = np.column_stack([unit * flat_c + Bt * flat_b, unit * slope_c + Bt * slope_b]
                               + [unit * np.exp(-af / d) for d in PN_CLUTTER_DECAYS_HZ]
                               + [Bt * g2 / ((fc - fb) ** 2 + g2)])
        P.append(O.power[j]); S.append(O.background[j]); K.append(kern); F.append(np.full(len(fc), fold[i]))
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
    # the skirt's shape as measured (wider than this test's band), for the extension
    d = skirt_ordinates(M, cfg)
    profile = skirt_profile(M, cfg, d)
    if profile is not None:
        res.params["skirt_profile"] = profile
    res.fit = {"q_flat": q_flat, "q_slope": q_slope, "bandwidth_hz": float(bw), "offset_hz": float(SKIRT_OFFSET_HZ)}
    res.effect = rise_model
    res.relevant = rise_model >= cfg.margin_floor_rise_db
    # the profile is read by medians: the target's lines among the ordinates (where
    # the model misplaces them: a wrong blade count, a speed scale) lift this test's
    # mean-based fit, not the medians. A skirt the medians put more than
    # PN_PROFILE_AGREE_DB below this fit is no skirt: not relevant.
    at_offset = None
    if profile is not None:
        e = np.asarray(profile["band_edges_hz"])
        jb = int(np.clip(np.searchsorted(e, SKIRT_OFFSET_HZ, side="right") - 1, 0, len(profile["dbc_hz"]) - 1))
        at_offset = float(profile["dbc_hz"][jb])
        res.relevant = res.relevant and at_offset >= skirt - PN_PROFILE_AGREE_DB
    # the second reading: the measured profile, fitted by medians on one fold, scored
    # on the other over the whole band (35 Hz to 1.2 kHz). Where the body sits next
    # to the clutter line, this test's 35-95 Hz ordinates lie on one side only and
    # its body-spread column takes up the skirt; the wide band sees the skirt on both
    # sides and far from the body. Used when it gives more held-out evidence and the
    # floor rise it finds by medians in its innermost band passes the margin.
    # the body's spread as the model with a skirt fits it (its weight per unit line power)
    spread = float(xe[-1] / norm[-1]) if len(xe) > NQ else 0.0
    prof = None if d is None or profile is None else profile_skirt_test(d, fold, spread)
    if prof is not None:
        use_prof = bool(prof["test"].held_out and prof["test"].log_e > res.log_e
                        and prof["rise_db"] >= cfg.margin_floor_rise_db and prof["fall_db"] >= PN_PROFILE_FALL_DB)
        if use_prof:
            t = prof["test"]
            res.log_e, res.nll_base, res.nll_ext, res.n_obs, res.held_out = (t.log_e, t.nll_base, t.nll_ext,
                                                                             t.n_obs, t.held_out)
            res.statistic = t.statistic
            res.effect, res.relevant = prof["rise_db"], True
        res.evidence["profile_test"] = {"log_evalue": round(float(prof["test"].log_e), 2),
                                        "floor_rise_db": round(float(prof["rise_db"]), 2),
                                        "fall_db": round(min(float(prof["fall_db"]), 999.0), 2), "used": use_prof}
    res.evidence.update({"floor_rise_db_vs_background": round(rise_meas, 2),
                         "model_floor_rise_db": round(rise_model, 2),
                         "skirt_profile_dbc_hz_at_offset": None if at_offset is None else round(at_offset, 2),
                         "rms_rad": round(rms, 4), "skirt_dbc_hz": round(skirt, 2),
                         "n_ordinates": int(len(P)),
                         "skirt_flat_and_sloped": [round(q_flat, 6), round(q_slope, 6)],
                         "nuisance_clutter_spread": [round(float(v), 4) for v in xe[NQ:]]})
    return res


CAUSE_ORDER = ("sideband_asymmetry", "sideband_fading", "body_fluctuation", "motor_log_lag",
               "motor_speed_scale", "phase_noise", "blade_imbalance")
#: causes whose tests need the body line (not testable when it lies in the clutter notch)
BODY_CAUSES = ("body_fluctuation", "phase_noise")
#: causes whose tests need the rotors' HERM lines
ROTOR_CAUSES = ("sideband_asymmetry", "sideband_fading", "motor_log_lag", "motor_speed_scale", "blade_imbalance")
#: pairs of causes whose statistics depend on each other: the test of one is redone
#: with the other's extension in both models once the other is named. Every other
#: cause's statistic is unchanged by another cause's extension in both models (the
#: held-out likelihood ratio is the same number): the asymmetry statistic is a
#: ratio of upper to lower sidebands (a common blade gain, i.e. fading, cancels); the
#: fading statistic is the common-mode sideband power relative to each harmonic's
#: median (a constant per-side gain, i.e. asymmetry, cancels, and so do lag and
#: scale, since the sidebands are read where the measured lines are and the
#: envelope's speed tilt is taken out at the measured speed); the body
#: statistic reads the body line only; the phase-noise likelihood keeps the body's
#: own skirt (a fluctuating body) and the wind-blown clutter in both models.
#: The sideband tests depend on phase noise the other way: its skirt raises the floor
#: under the sidebands near the clutter line, where the raised-floor guard drops them;
#: with phase noise named, they are read with its fitted skirt in the floor's model
#: (:func:`.measure.given_skirt`, both models), so the sideband causes are judged on
#: what the skirt leaves. Phase noise's own test reads the floor off the
#: target's lines and does not change with a sideband cause.
#: Likewise a named blade imbalance: its rotation-rate lines lie between the
#: blade-passing lines and lift the sidebands' local floor (:func:`.measure.given_imbalance`);
#: the imbalance's own test reads the rotation lines and does not change with them.
LOG_COUPLED = {"motor_log_lag": {"motor_speed_scale"}, "motor_speed_scale": {"motor_log_lag"}}
FLOOR_PARTNERS = frozenset({"phase_noise", "blade_imbalance"})
SKIRT_COUPLED = {"sideband_asymmetry": set(FLOOR_PARTNERS), "sideband_fading": set(FLOOR_PARTNERS)}
COUPLED = {**LOG_COUPLED, **SKIRT_COUPLED}


@dataclass(frozen=True)
class TestResults:
    """Every cause's test of one flight (:func:`run_tests`).

    ``tests``: cause -> :class:`CauseTest` against the paper's model (no cause named);
    ``conditional``: (cause, partners) -> the cause's test with the extensions of
    ``partners`` (a non-empty frozenset of its :data:`COUPLED` partners) in both
    models, for every testable coupled cause (:func:`.decide.tests_given` assembles
    the tests with any set of named causes in both models from the two)."""

    __test__ = False  # not a pytest class

    tests: dict
    conditional: dict


def check_testable(M: Measurements, tests: dict, cfg: DiagnosisConfig) -> None:
    """:class:`~.measure.Undiagnosable` when the measurement leaves nothing to test:
    too few usable CPIs, or no test of the rotors' lines possible (none visible)."""
    fid = M.flight_id
    nv = int(M.valid.sum())
    if nv < 2 * cfg.block_cpis or not any(t.testable for t in tests.values()):
        problem = (f"has {nv} of {len(M.t_s)} CPIs usable (body Doppler outside the clutter notch, "
                   f"no floor artifact, within the motor log's span)")
        expected = f">= {2 * cfg.block_cpis} usable CPIs"
        raise Undiagnosable(fid, "iq", problem, expected,
                            reason=f"too few usable CPIs: iq: {problem} (expected {expected})")
    if not any(tests[c].testable for c in ROTOR_CAUSES):
        problem = ("shows no rotor lines: no HERM sideband pair above the noise and too few CPIs whose line "
                   "pattern matches the motor log's")
        raise Undiagnosable(fid, "iq", problem, "visible HERM lines of the rotors",
                            reason=f"no visible rotor sidebands: iq: {problem}")


def run_tests(M: Measurements, cfg: DiagnosisConfig) -> TestResults:
    """Every cause's :class:`CauseTest` of the measured flight ``M``: against the
    paper's model, and for the :data:`COUPLED` causes also with their partners in
    both models (:class:`TestResults`).

    A motor log estimated from the recording's own HERM lines (``M.log_from_radar``)
    cannot be late or scaled against them: lag and scale are then not testable.

    Raises
    ------
    Undiagnosable
        When nothing is left to test (:func:`check_testable`).
    """
    fold = folds(len(M.t_s), cfg.block_cpis)
    lag, sc = test_log(M, cfg, fold)
    tests = {
        "sideband_asymmetry": test_asymmetry(M, cfg, fold),
        "sideband_fading": test_fading(M, cfg, fold),
        "body_fluctuation": test_body(M, cfg, fold),
        "motor_log_lag": lag,
        "motor_speed_scale": sc,
        "phase_noise": test_phase_noise(M, cfg, fold),
        "blade_imbalance": test_imbalance(M, cfg, fold),
    }
    if M.info.get("body_in_notch"):
        for name in BODY_CAUSES:
            tests[name] = CauseTest(name, testable=False, evidence={
                "reason": "body Doppler inside the clutter notch (hovering, on a stand or a staring recording): "
                          "the body line is not measurable"})
    if M.log_from_radar:
        for name in ("motor_log_lag", "motor_speed_scale"):
            tests[name].testable = False
            tests[name].evidence = {"reason": "motors_source is radar: the motor log was estimated from this "
                                              "recording's HERM lines, so lag and scale are not testable"}
    check_testable(M, tests, cfg)
    conditional = {}
    for cause, partners in LOG_COUPLED.items():
        if not tests[cause].testable:
            continue
        for r in range(1, len(partners) + 1):
            for g in combinations(sorted(partners), r):
                lag_g, sc_g = test_log(M, cfg, fold, frozenset(g))
                conditional[(cause, frozenset(g))] = {"motor_log_lag": lag_g, "motor_speed_scale": sc_g}[cause]
    conditional.update(tests_given_skirt(M, cfg, fold, tests))
    return TestResults(tests, conditional)


def tests_given_skirt(M: Measurements, cfg: DiagnosisConfig, fold, tests: dict) -> dict:
    """The sideband tests (:data:`SKIRT_COUPLED`) with what lifts the floor under the
    sidebands in its model, keyed ``(cause, partners)`` as
    :attr:`TestResults.conditional`, for every non-empty set of the available
    partners: the phase-noise skirt fitted by ``tests["phase_noise"]``
    (:func:`.measure.given_skirt`; available when phase noise is testable and its
    skirt not nil) and a blade imbalance's rotation lines
    (:func:`.measure.given_imbalance`; available when the imbalance test is testable
    and favours the imbalance on held-out data). Empty when neither is. A test whose
    pairs the partners do not change is the same object."""
    available = []
    pn = tests.get("phase_noise")
    if pn is not None and pn.testable and pn.fit and pn.fit["q_flat"] + pn.fit["q_slope"] > 0:
        q = (pn.fit["q_flat"], pn.fit["q_slope"], pn.fit["bandwidth_hz"], pn.fit["offset_hz"])
        available.append("phase_noise")
    imb = tests.get("blade_imbalance")
    if imb is not None and imb.testable and imb.log_e > 0:
        available.append("blade_imbalance")
    out = {}
    m_imb = given_imbalance(M) if "blade_imbalance" in available else M   # once for both sets holding it
    for r in range(1, len(available) + 1):
        for g in combinations(available, r):
            base = m_imb if "blade_imbalance" in g else M
            # the asymmetry reads both sides of a pair; the fading the pair's sum, which
            # one side clear of the skirt stands for (given_skirt's clear_side)
            if "phase_noise" in g:
                run = {"sideband_asymmetry": (test_asymmetry, given_skirt(base, *q)),
                       "sideband_fading": (test_fading, given_skirt(base, *q, clear_side=True))}
            else:
                run = {"sideband_asymmetry": (test_asymmetry, base), "sideband_fading": (test_fading, base)}
            for cause in SKIRT_COUPLED:
                test, Ms = run[cause]
                changed = not (np.array_equal(Ms.pair_ok, M.pair_ok) and np.array_equal(Ms.up, M.up)
                               and np.array_equal(Ms.lo, M.lo))
                t = test(Ms, cfg, fold) if changed else tests[cause]
                if changed and t.testable:
                    n_new = int((Ms.pair_ok & ~M.pair_ok & M.valid[:, None]).sum())
                    if "phase_noise" in g:
                        t.evidence = {**t.evidence, "phase_noise_skirt_in_floor_model": True,
                                      "pairs_kept_on_the_skirt": n_new}
                    if "blade_imbalance" in g:
                        t.evidence = {**t.evidence, "rotation_lines_in_floor_model": True,
                                      "pairs_kept_beside_rotation_lines": n_new}
                out[(cause, frozenset(g))] = t
    return out


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
SHAPES = {"exponential": (lambda x: np.exp(-x), 1.0),
          "matern32": (lambda x: (1 + x) * np.exp(-x), 2.1462)}


def model_cov_db2(lags_s: np.ndarray, sigma_db, tau_s, ds: np.ndarray, W: np.ndarray,
                  shape: str = "exponential") -> np.ndarray:
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


def fit_gain_process(y: np.ndarray, valid: np.ndarray, noise_var_db2: np.ndarray, hop_s: float,
                     window: np.ndarray, prf_hz: float, *, max_lag_s: float = 10.0,
                     tau_bounds_s: tuple = (0.01, 30.0), min_pairs: int = 20, drift: bool = True,
                     noise_free: bool = False) -> dict:
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
    return fit_variogram(lags, g, npair, nv, hop_s, window, prf_hz, tau_bounds_s=tau_bounds_s,
                         min_pairs=min_pairs, drift=drift, noise_free=noise_free)


def fit_variogram(lags: np.ndarray, g: np.ndarray, npair: np.ndarray, nv: float, hop_s: float,
                  window: np.ndarray, prf_hz: float, *, tau_bounds_s: tuple = (0.01, 30.0),
                  min_pairs: int = 20, drift: bool = True, noise_free: bool = False) -> dict:
    """Fit (sigma [dB], T [s]) (and the nuisance drift) to a measured variogram ``g``
    [dB^2] at integer ``lags`` [hops] with ``npair`` pairs each, noise variance ``nv``
    [dB^2] (see :func:`fit_gain_process` for the other arguments and the result)."""
    ok = np.isfinite(g) & (npair >= min_pairs) & (g > 0)
    lags, g = lags[ok], g[ok]
    out = {"sigma_db": 0.0, "timescale_s": float("nan"), "lags_s": (lags * hop_s).tolist(),
           "variogram_db2": g.tolist(), "noise_db2": nv}
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
        gm = ((C[..., :1] - C[..., 1:])[:, :, None, None, :] + kap[None, None, :, None, None] * Ls
              + nug[None, None, None, :, None])
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
    out.update({"sigma_db": s_best, "timescale_s": t_best if s_best > 0 else float("nan"),
                "drift_db2_per_s": k_best,
                "variogram_fit_db2": np.asarray(fit).tolist()})
    return out


def fit_gain_process_ml(y: np.ndarray, valid: np.ndarray, noise_var_db2: np.ndarray, hop_s: float,
                        window: np.ndarray, prf_hz: float, start: tuple, *, block: int = 512,
                        tau_bounds_s: tuple = (0.01, 30.0), design: np.ndarray | None = None,
                        free_white: bool = False) -> dict:
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
    out = {"sigma_db": float(start[0]), "timescale_s": float(start[1]), "nll": float("nan"), "n_eval": 0,
           "extra_white_db2": 0.0}
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
    r = minimize(nll, x0, method="Nelder-Mead",
                 options={"xatol": 0.005, "fatol": 0.01, "maxiter": 300 if not free_white else 600})
    if np.isfinite(r.fun) and r.fun < 1e11:
        out.update({"sigma_db": float(np.exp(r.x[0])), "timescale_s": float(np.exp(r.x[1])), "nll": float(r.fun),
                    "n_eval": int(r.nfev), "extra_white_db2": float(np.exp(r.x[2])) if free_white else 0.0})
    return out
