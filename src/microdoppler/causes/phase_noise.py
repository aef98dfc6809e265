"""``phase_noise``: the radar's phase noise spreading strong lines into a raised skirt.

- catalog: ``rms_rad`` [rad] (the flat 100 Hz band-limited process's rms) and
  ``skirt_dbc_hz`` [dBc/Hz] (its single-sideband density at 50 Hz,
  :func:`flat_skirt_dbc_hz`; either defines the other);
- test (:func:`test_phase_noise`): Whittle likelihood of the periodogram ordinates
  near the clutter line (off the target's lines): baseline PSD = the background
  recording's, extension adds a skirt around the clutter line and the body; a second
  reading from the measured skirt profile (:func:`profile_skirt_test`); needs the
  body line;
- a floor partner: named, its skirt enters the model of the floor under the
  sidebands (:func:`.measure.given_skirt`);
- twins: the echo is multiplied by exp(j theta(t)), theta Gaussian with a flat
  spectrum on |f| < 100 Hz (:func:`flat_phase_noise`) or the measured skirt's
  (:func:`profile_phase_noise`, optional ``skirt_profile``), on the injected
  background too (``acts_on_background``);
- emulator: the whole flight echo (target, clutter, noise) is multiplied by
  exp(j theta(t)) of the flat process.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np
import scipy.fft as sfft

from ..errors import InputError
from .base import CauseSpec, Param, number
from .config import DiagnosisConfig
from .heldout import CauseTest, _crossfit
from .measure import (
    DB,
    given_skirt,
    ordinate_subset,
    robust_skirt_levels,
    skirt_ordinates,
    skirt_power,
    skirt_profile,
    skirt_shape,
)

NAME = "phase_noise"
#: sub-seed of the twins' phase-noise process (independent streams from one seed)
STREAM = 3
PHASE_NOISE_BANDWIDTH_HZ = 100.0
#: offset from the carrier at which ``skirt_dbc_hz`` is read [Hz]
SKIRT_OFFSET_HZ = 50.0


def flat_skirt_dbc_hz(
    rms_rad: float, bandwidth_hz: float = PHASE_NOISE_BANDWIDTH_HZ, offset_hz: float = SKIRT_OFFSET_HZ
) -> float:
    """``skirt_dbc_hz`` of the catalog's flat phase noise of rms ``rms_rad`` [rad].

    theta(t) Gaussian with a flat two-sided PSD S = rms^2 / (2 B) on |f| < B. The
    spectrum of exp(j theta) relative to its carrier (weight exp(-rms^2)) is
    L(f) = sum_n S_n(f) / n! (S_n: S convolved with itself n times); the first two terms are kept (the third is below
    1e-4 of the first for rms < 0.1 rad): L(f) = S + S^2 (2B - |f|) / 2 [1/Hz].
    Returns 10 log10 L(offset_hz) [dBc/Hz]; -inf for rms 0.
    """
    a = float(rms_rad) ** 2 / (2 * bandwidth_hz)
    lin = a + 0.5 * a * a * max(2 * bandwidth_hz - offset_hz, 0.0)
    return float(10 * np.log10(lin)) if lin > 0 else float("-inf")


def flat_rms_rad(
    skirt_dbc_hz: float, bandwidth_hz: float = PHASE_NOISE_BANDWIDTH_HZ, offset_hz: float = SKIRT_OFFSET_HZ
) -> float:
    """Inverse of :func:`flat_skirt_dbc_hz`: the flat process's rms [rad]."""
    L = 10 ** (float(skirt_dbc_hz) / 10)
    c = max(2 * bandwidth_hz - offset_hz, 0.0)
    a = L if c == 0 else (np.sqrt(1 + 2 * c * L) - 1) / c
    return float(np.sqrt(2 * bandwidth_hz * a))


def profile_skirt_test(
    d: dict, fold, body_spread: float = 0.0, body_guard_hz: float | None = None, *, cfg: DiagnosisConfig | None = None
) -> dict:
    """The measured skirt as a held-out test (:func:`test_phase_noise`'s second
    reading): on each fold the band levels by medians, in the bands measured on both
    sides of the clutter line (:func:`.measure.robust_skirt_levels`), scored on the other fold's ordinates by a
    Whittle likelihood against the background alone, each ordinate's power
    winsorised at ln(100) x the extended model's mean (a line among the ordinates
    then adds at most what a 1 % tail does); only ordinates at least
    ``body_guard_hz`` (default ``cfg.pn_profile_body_guard_hz``; ``cfg`` default
    :class:`DiagnosisConfig`'s) from the body, and the body's Lorentzian spread of weight
    ``body_spread`` (the phase-noise test's nuisance column) in the background of
    both models (a fluctuating body's spread). Returns ``{"test": CauseTest, "rise_db":
    the floor rise, by medians on the whole flight, over the ordinates of the
    innermost band measured on both sides of the clutter line, and ``fall_db``: how
    far the levels fall from that band to the outermost measured one (a skirt falls;
    a flat excess over the whole band is the target's spread, not the radar's
    skirt)}``."""
    t = CauseTest(
        "phase_noise",
        statistic="held-out Whittle likelihood of the floor 35 Hz-1.2 kHz from the "
        "clutter line, the skirt's band levels by medians",
    )
    # off the body's own spread: a fluctuating body beside the clutter line spreads on
    # both sides of it too; its Lorentzian tail (as the phase-noise test's model with
    # a skirt fits it) is part of the background in both models
    cfg = DiagnosisConfig() if cfg is None else cfg
    body_guard_hz = cfg.pn_profile_body_guard_hz if body_guard_hz is None else body_guard_hz
    if body_spread > 0:
        g2 = cfg.pn_body_skirt_hz**2
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
        # default: pn_clutter_decays_hz) and a skirt around the body (a fluctuating
        # body spreads its own line)
        Bt = max(float(O.body_pow[j]), 0.0) * df / (2 * bw)
        g2 = cfg.pn_body_skirt_hz**2
        # the skirt: flat, and falling as (f0 / f)^2 (f0 = 50 Hz), around the clutter
        # line and the body both; a mix of the two follows a flat, a Gaussian or a
        # 1/f-like phase-noise spectrum between pn_inner_hz and pn_outer_hz
        db_ = np.abs(fc - fb)
        flat_c, slope_c = skirt_shape(af, bw, SKIRT_OFFSET_HZ)
        flat_b, slope_b = skirt_shape(db_, bw, SKIRT_OFFSET_HZ)
        kern = np.column_stack(
            [unit * flat_c + Bt * flat_b, unit * slope_c + Bt * slope_b]
            + [unit * np.exp(-af / d) for d in cfg.pn_clutter_decays_hz]
            + [Bt * g2 / ((fc - fb) ** 2 + g2)]
        )
        P.append(O.power[j])
        S.append(O.background[j])
        K.append(kern)
        F.append(np.full(len(fc), fold[i]))
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
    # pn_profile_agree_db below this fit is no skirt: not relevant.
    at_offset = None
    if profile is not None:
        e = np.asarray(profile["band_edges_hz"])
        jb = int(np.clip(np.searchsorted(e, SKIRT_OFFSET_HZ, side="right") - 1, 0, len(profile["dbc_hz"]) - 1))
        at_offset = float(profile["dbc_hz"][jb])
        res.relevant = res.relevant and at_offset >= skirt - cfg.pn_profile_agree_db
    # the second reading: the measured profile, fitted by medians on one fold, scored
    # on the other over the whole band (35 Hz to 1.2 kHz). Where the body sits next
    # to the clutter line, this test's 35-95 Hz ordinates lie on one side only and
    # its body-spread column takes up the skirt; the wide band sees the skirt on both
    # sides and far from the body. Used when it gives more held-out evidence and the
    # floor rise it finds by medians in its innermost band passes the margin.
    # the body's spread as the model with a skirt fits it (its weight per unit line power)
    spread = float(xe[-1] / norm[-1]) if len(xe) > NQ else 0.0
    prof = None if d is None or profile is None else profile_skirt_test(d, fold, spread, cfg=cfg)
    if prof is not None:
        use_prof = bool(
            prof["test"].held_out
            and prof["test"].log_e > res.log_e
            and prof["rise_db"] >= cfg.margin_floor_rise_db
            and prof["fall_db"] >= cfg.pn_profile_fall_db
        )
        if use_prof:
            t = prof["test"]
            res.log_e, res.nll_base, res.nll_ext, res.n_obs, res.held_out = (
                t.log_e,
                t.nll_base,
                t.nll_ext,
                t.n_obs,
                t.held_out,
            )
            res.statistic = t.statistic
            res.effect, res.relevant = prof["rise_db"], True
        res.evidence["profile_test"] = {
            "log_evalue": round(float(prof["test"].log_e), 2),
            "floor_rise_db": round(float(prof["rise_db"]), 2),
            "fall_db": round(min(float(prof["fall_db"]), 999.0), 2),
            "used": use_prof,
        }
    res.evidence.update(
        {
            "floor_rise_db_vs_background": round(rise_meas, 2),
            "model_floor_rise_db": round(rise_model, 2),
            "skirt_profile_dbc_hz_at_offset": None if at_offset is None else round(at_offset, 2),
            "rms_rad": round(rms, 4),
            "skirt_dbc_hz": round(skirt, 2),
            "n_ordinates": int(len(P)),
            "skirt_flat_and_sloped": [round(q_flat, 6), round(q_slope, 6)],
            "nuisance_clutter_spread": [round(float(v), 4) for v in xe[NQ:]],
        }
    )
    return res


def check_skirt_profile(profile, source="extensions") -> dict:
    """Validate a phase-noise ``skirt_profile`` (``{"band_edges_hz": [n + 1],
    "dbc_hz": [n]}``: the measured skirt, piecewise constant per band of offset;
    :func:`microdoppler.causes.measure.skirt_profile`); returns it as floats."""
    key = "extensions.phase_noise.skirt_profile"
    want = "{band_edges_hz: [n + 1 increasing offsets > 0 Hz], dbc_hz: [n levels, dBc/Hz]}"
    if not isinstance(profile, Mapping) or "band_edges_hz" not in profile or "dbc_hz" not in profile:
        raise InputError(source, key, f"is {profile!r}", want)
    try:
        e = np.asarray(profile["band_edges_hz"], float)
        v = np.asarray(profile["dbc_hz"], float)
    except (TypeError, ValueError):
        raise InputError(source, key, "holds values that are not numbers", want) from None
    if (
        e.ndim != 1
        or v.ndim != 1
        or len(e) != len(v) + 1
        or len(v) < 1
        or not np.all(np.isfinite(e))
        or not np.all(np.isfinite(v))
        or e[0] <= 0
        or np.any(np.diff(e) <= 0)
        or np.any(v > 0)
    ):
        raise InputError(source, key, f"has {len(e)} edges and {len(v)} levels", want + ", levels finite and <= 0")
    out = {"band_edges_hz": [float(x) for x in e], "dbc_hz": [float(x) for x in v]}
    if "n_ordinates" in profile:
        out["n_ordinates"] = [int(x) for x in profile["n_ordinates"]]
    return out


def flat_phase_noise(
    n: int, prf_hz: float, rms_rad: float, rng: np.random.Generator, bandwidth_hz: float = PHASE_NOISE_BANDWIDTH_HZ
) -> np.ndarray:
    """Gaussian phase error theta: float64 [n] [rad], flat spectrum on 0 < |f| <
    ``bandwidth_hz``, standard deviation ``rms_rad``."""
    if n == 0 or rms_rad == 0:
        return np.zeros(n)
    th = _gaussian_series(n, prf_hz, lambda f: ((f > 0) & (f < bandwidth_hz)).astype(np.float64), rng)
    s = th.std()
    return th * (rms_rad / s) if s > 0 else th


def _gaussian_series(n: int, prf_hz: float, amplitude, rng: np.random.Generator) -> np.ndarray:
    """A real Gaussian series [n] drawn in the frequency domain over the whole record:
    complex white noise times ``amplitude(f)`` on the real FFT's frequencies [Hz]
    (of the next fast length), transformed back."""
    m = sfft.next_fast_len(n, real=True)
    f = sfft.rfftfreq(m, 1.0 / prf_hz)
    spec = (rng.standard_normal(len(f)) + 1j * rng.standard_normal(len(f))) * amplitude(f)
    return sfft.irfft(spec, m, workers=1)[:n]


def profile_phase_noise(n: int, prf_hz: float, band_edges_hz, dbc_hz, rng: np.random.Generator) -> np.ndarray:
    """Gaussian phase error theta: float64 [n] [rad] whose two-sided spectrum is the
    measured skirt (first order, L(f) = S_theta(f)): 10^(dbc/10) [rad^2/Hz] in each
    band of |f| (``band_edges_hz``), the first band's level below its lower edge (the
    skirt within the clutter notch is not measured; flat there as the catalog's
    process), none beyond the last edge."""
    if n == 0:
        return np.zeros(n)
    m = sfft.next_fast_len(n, real=True)
    e = np.asarray(band_edges_hz, float)
    lev = 10 ** (np.asarray(dbc_hz, float) / 10)

    def amplitude(f):
        j = np.clip(np.searchsorted(e, f, side="right") - 1, 0, len(lev) - 1)
        S = np.where(f < e[-1], lev[j], 0.0)
        S[0] = 0.0
        # rfft coefficients of a real series with two-sided PSD S: variance S prf m / 2 per part
        return np.sqrt(S * prf_hz * m / 2)

    return _gaussian_series(n, prf_hz, amplitude, rng)


def world_phase_noise_params(p: dict) -> dict:
    """rms_rad and skirt_dbc_hz of the emulator's flat process, either one given."""
    p = dict(p)
    try:
        vals = {k: float(v) for k, v in p.items()}
    except (TypeError, ValueError):
        raise ValueError(f"effect {NAME!r}: parameters {p} must be numbers") from None
    if "rms_rad" in vals and vals["rms_rad"] < 0:
        raise ValueError(f"{NAME}: rms_rad={vals['rms_rad']} must be >= 0")
    if "rms_rad" in vals and "skirt_dbc_hz" in vals:
        want = flat_skirt_dbc_hz(vals["rms_rad"]) if vals["rms_rad"] > 0 else -300.0
        if not abs(want - vals["skirt_dbc_hz"]) <= 0.1:
            raise ValueError(
                f"{NAME}: skirt_dbc_hz={vals['skirt_dbc_hz']} disagrees with rms_rad="
                f"{vals['rms_rad']} (whose flat skirt is {want:.2f} dBc/Hz); give one of them"
            )
    elif "rms_rad" in vals:
        p["skirt_dbc_hz"] = flat_skirt_dbc_hz(vals["rms_rad"]) if vals["rms_rad"] > 0 else -300.0
    elif "skirt_dbc_hz" in vals:
        p["rms_rad"] = flat_rms_rad(vals["skirt_dbc_hz"])
    return p


class PhaseNoise(CauseSpec):
    name = NAME
    meaning = "the radar's phase noise spreads strong lines into a raised skirt"
    params = (
        Param(
            "rms_rad",
            "rad",
            "rms of the radar phase error theta(t), Gaussian, band-limited to "
            "|f| < 100 Hz (flat PSD); multiplies the whole echo incl. clutter by exp(j theta). For "
            "another spectral shape: the rms of the flat process with the same skirt at 50 Hz",
            "raises the floor within 100 Hz of the clutter line by >= 6 dB",
        ),
        Param(
            "skirt_dbc_hz",
            "dBc/Hz",
            "single-sideband phase-noise density at 50 Hz from the carrier, "
            "relative to the carrier (any spectral shape; for the flat process "
            ":func:`flat_skirt_dbc_hz` of rms_rad)",
            ">= about -75 dBc/Hz",
        ),
    )
    observations = (
        "floor_ordinates",
        "stft",
        "bg_stft",
        "sim_stft",
        "calib",
        "floor",
        "body_pow",
        "f_body_hz",
        "f_log_hz",
        "dil",
        "valid",
        "info",
    )
    line = "body"
    floor_partner = True
    floor_stage = 1  # the skirt enters the floor's model after a named imbalance's lines
    floor_side_aware = True
    margin_field = "margin_floor_rise_db"
    bounds = (("rms_rad", ">= 0"),)
    acts_on_background = True

    def test(self, M, cfg, fold, given=frozenset()):
        return test_phase_noise(M, cfg, fold)

    def floor_available(self, test) -> bool:
        # testable and its skirt not nil
        return bool(test is not None and test.testable and test.fit and test.fit["q_flat"] + test.fit["q_slope"] > 0)

    def floor_model(self, M, test, *, clear_side=False):
        q = (test.fit["q_flat"], test.fit["q_slope"], test.fit["bandwidth_hz"], test.fit["offset_hz"])
        # the asymmetry reads both sides of a pair; the fading the pair's sum, which
        # one side clear of the skirt stands for (given_skirt's clear_side)
        return given_skirt(M, *q, clear_side=True) if clear_side else given_skirt(M, *q)

    def floor_evidence(self, n_new):
        return {"phase_noise_skirt_in_floor_model": True, "pairs_kept_on_the_skirt": n_new}

    def extra_params(self, params):
        profile = params.pop("skirt_profile", None)
        return {} if profile is None else {"skirt_profile": profile}

    def complete_params(self, params, source):
        # either parameter defines the other for the flat process (an old file has rms_rad only)
        if "rms_rad" not in params and "skirt_dbc_hz" in params:
            v = number(source, NAME, "skirt_dbc_hz", params["skirt_dbc_hz"])
            params["rms_rad"] = flat_rms_rad(v)
        elif "skirt_dbc_hz" not in params and "rms_rad" in params:
            v = number(source, NAME, "rms_rad", params["rms_rad"])
            params["skirt_dbc_hz"] = flat_skirt_dbc_hz(v) if v > 0 else -300.0

    def check_extra(self, extra, source):
        return {"skirt_profile": check_skirt_profile(extra["skirt_profile"], source)}

    def post(self, p, iq, *, prf_hz, seed):
        rng = np.random.default_rng([int(seed), STREAM])
        if "skirt_profile" in p:
            th = profile_phase_noise(
                len(iq), prf_hz, p["skirt_profile"]["band_edges_hz"], p["skirt_profile"]["dbc_hz"], rng
            )
        else:
            th = flat_phase_noise(len(iq), prf_hz, p["rms_rad"], rng)
        return (iq * np.exp(1j * th)).astype(np.complex64)

    def world_params(self, full):
        return world_phase_noise_params(full)

    def world_check(self, full):
        if not full["rms_rad"] >= 0:
            raise ValueError(f"{NAME}: rms_rad={full['rms_rad']} must be >= 0")

    def world_phase_rms(self, p):
        return p["rms_rad"]

    def gof_guard(self, guard_hz):
        # its whole skirt band (the catalog's flat skirt need not have the measured
        # shape), and the edge of the body's skirt, whose shape the flat process does not know;
        # the hook has no settings: the phase-noise ordinates' default outer edge
        return max(guard_hz, 2 * DiagnosisConfig().pn_outer_hz), (
            0.75 * PHASE_NOISE_BANDWIDTH_HZ,
            4.5 * PHASE_NOISE_BANDWIDTH_HZ,
        )


CAUSE = PhaseNoise()
