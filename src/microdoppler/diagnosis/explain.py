"""Step 4 of the diagnosis: what the named causes explain, and what they leave.

:func:`goodness_of_fit` compares the measured spectrogram with the calibrated paper's
model extended by every named cause, band by band relative to the body Doppler: a
band whose residual exceeds what the flight's own scatter allows (significant,
replicated in both folds, at least ``margin_excess_db``) makes the flight
``unexplained``; so does a HERM line anywhere in the Doppler band that one of the two
holds and the other lacks (:func:`line_presence`: the model's lines where the
recording has none, or the recording's beyond the declared tips), so that ``none``
means that the model explains the recording both ways.
:func:`plot_diagnosis` shows the measured spectrogram, the baseline, the model with
every named cause's extension, its residual with the unexplained band marked, and the
statistic that named the first cause (or the strongest test when none was named)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy.fft as sfft
from scipy.stats import norm
from scipy.stats import t as student_t

from ..causes import registry
from ..causes.extensions import ExtensionSet
from ..causes.measure import thin_wire_line_power
from ..spectra.lines import band_power as _band_power_row
from ..synthesis.model import ModelExtensions, Track, add_noise

from .config import DiagnosisConfig
from .decide import Decision
from .hypotheses import folds
from .measure import DB, Measurements, body_doppler, cpi_average, refine_peak, simulate_blades, stft_power


def simulate_flight(flight, M: Measurements, ext: ExtensionSet | None, seed: int, n_fft: int) -> np.ndarray:
    """The paper's model of ``flight`` (calibrated), optionally extended, plus the
    flight's background recording (or white noise at its floor); a named phase noise
    acts on the background too, as in the twins (:func:`microdoppler.causes.twins.inject`).

    The blades are simulated relative to the body and their mean return (every
    component within half the rotation rate of the body Doppler) is taken out, as
    part of the body's RCS, before the extensions' slow blade gain (a fading) acts on
    them: the body line is S_body as measured, and a fading blade gain does not spread
    it."""
    prf = flight.prf_hz
    n = len(flight.iq)
    w2 = float((M.stft.window**2).sum())
    good = M.valid & (M.body_pow > 0)
    amp = float(np.sqrt(np.median(M.body_pow[good]) / (n_fft * w2))) if good.any() else 1.0
    calib, log = M.calib, M.log
    s_blade = calib.s_blade if np.isfinite(calib.s_blade) else 0.0
    alpha = calib.alpha_s if np.isfinite(calib.alpha_s) else 0.0
    a = flight.attrs
    n_blades = int(a["n_blades"])
    lg = ext.transform_log(log) if ext is not None else log
    extensions = ext.model_extensions(prf_hz=prf, n_pulses=n, seed=seed) if ext is not None else ModelExtensions()
    track = Track.from_tracker(flight.track_time_s, flight.track_range_m, flight.track_radial_velocity_mps)
    common = dict(
        wavelength_m=flight.wavelength_m,
        n_blades=n_blades,
        blade_length_m=float(a["blade_length_m"]),
        n_fft=n_fft,
        seed=seed,
    )
    blades, rev = simulate_blades(
        lg,
        n,
        prf,
        **common,
        extensions=replace(extensions, body_hook=None, blade_hook=None),
        alpha_s=alpha,
        s_blade=amp * s_blade,
        s_body=0.0,
        blade_amplitudes=ext.blade_amplitudes(n_blades) if ext is not None else None,
    )
    f_rot = float(np.median(rev)) if rev.size else 0.0
    spec = sfft.fft(blades.astype(np.complex128))
    spec[np.abs(sfft.fftfreq(n, 1.0 / prf)) < f_rot / 2] = 0.0
    blades = sfft.ifft(spec)
    if extensions.blade_hook is not None:
        # the blades' slow gain (a fading) on the blades without their mean return:
        # on it, the gain would spread a line 20 dB above the sidebands into a
        # skirt beyond half the rotation rate that the measured body line does not have
        extensions.blade_hook(0, n, np.arange(n, dtype=np.float64) / prf, blades)
    body, _ = simulate_blades(
        lg,
        n,
        prf,
        **common,
        extensions=ModelExtensions(body_hook=extensions.body_hook),
        s_blade=0.0,
        s_body=amp,
        track=track,
    )
    body = body.astype(np.complex128)
    iq = body + blades * body / np.maximum(np.abs(body), 1e-30)
    if ext is not None:
        iq = ext.post(iq.astype(np.complex64), prf_hz=prf, seed=seed)
    if flight.background_iq is not None:
        # as the twins are injected: a named phase noise acts on the clutter too
        from ..causes.twins import inject

        iq = inject(iq, flight.background_iq, effects=ext.effects if ext is not None else None, prf_hz=prf, seed=seed)
    else:
        floor = float(np.median(M.floor)) / w2
        iq = add_noise(iq.astype(np.complex64), floor, seed + 1)
    return iq.astype(np.complex64)


def named_extensions(D: Decision) -> ExtensionSet | None:
    """Every named cause's extension (the report's own parameters), or None."""
    causes = [c for c in D.entry["causes"] if c.get("extension")]
    if not causes:
        return None
    return ExtensionSet({c["extension"]["name"]: c["extension"]["params"] for c in causes})


def band_power(
    spec,
    i: int,
    f_body_hz: float,
    bw: float,
    n_side: int,
    guard: float,
    body_half: float,
    skirt_edge: tuple | None = None,
) -> np.ndarray:
    """The goodness of fit's bands of CPI ``i`` of ``spec`` (an STFT power): the mean
    power per band of width ``bw`` centred on multiples of ``bw`` from the body
    Doppler ``f_body_hz`` (``2 n_side + 1`` bands), leaving out the clutter line's
    ``|f| <= guard``, the body's ``|f - f_body| <= body_half`` and, when given, the
    skirt's edge ``skirt_edge[0] <= |f - f_body| <= skirt_edge[1]`` [Hz]; NaN where
    fewer than 3 bins remain."""
    n_bands = 2 * n_side + 1
    rel = spec.f_hz - f_body_hz
    b = np.rint(rel / bw).astype(int) + n_side
    ok = (b >= 0) & (b < n_bands) & (np.abs(spec.f_hz) > guard) & (np.abs(rel) > body_half)
    if skirt_edge is not None:
        ok &= (np.abs(rel) < skirt_edge[0]) | (np.abs(rel) > skirt_edge[1])
    s = np.bincount(b[ok], spec.p[i, ok], minlength=n_bands)
    c = np.bincount(b[ok], minlength=n_bands)
    return np.where(c >= 3, s / np.maximum(c, 1), np.nan)


#: the median of n draws has about sqrt(pi / 2) times the standard error of their mean
_MEDIAN_EFF = float(np.sqrt(np.pi / 2))


def line_band_snr(spec, i: int, f_c: float, spacing_hz: float, floor: float) -> float:
    """The power of CPI ``i`` of ``spec`` (an STFT power) within half a line spacing
    ``spacing_hz`` of ``f_c`` [Hz] (the line, its skirt and whatever folds there) over
    the noise power ``floor`` [per bin] in that band; NaN without bins."""
    s, nb = _band_power_row(spec.p[i], spec, f_c, 0.5 * spacing_hz)
    if nb < 1 or not floor > 0:
        return np.nan
    return (s - nb * floor) / (nb * floor)


def model_spacing_hz(M: Measurements, ext: ExtensionSet | None) -> np.ndarray:
    """The HERM line spacing of the model of :func:`simulate_flight` per CPI [Hz]:
    the blade count times the log's speed, as the named causes' lag and scale move
    it (``ext.transform_log``)."""
    B = int(M.info["n_blades"])
    if ext is None:
        return B * M.f_log_hz
    st, prf = M.stft, float(M.info["prf_hz"])
    lg = ext.transform_log(M.log)

    def cpi(log):
        return cpi_average(np.asarray(log.time_s, float), log.rpm.mean(axis=1) / 60.0, st.t_s, st.window, prf)

    ratio = cpi(lg) / np.maximum(cpi(M.log), 1e-9)
    return B * M.f_log_hz * ratio


def line_presence(
    M: Measurements,
    sim,
    f_sim_hz: np.ndarray,
    spacing_sim_hz: np.ndarray,
    *,
    guard: float,
    body_half: float,
    margin_db: float,
    wire_power: np.ndarray | None = None,
    cfg: DiagnosisConfig | None = None,
) -> dict:
    """The two-sided check: where does the model put a line the recording lacks, or
    the recording hold a line the model lacks, anywhere in the Doppler band?

    Every HERM line (order n = 1, 2, ... either side of the body, as far as the
    Nyquist band reaches) is read the same way in the measured spectrogram (its body
    ``M.f_body_hz``, its own measured spacing) and in the model's (``sim``, its body
    ``f_sim_hz`` and spacing ``spacing_sim_hz`` [Hz, per CPI]), on the valid CPIs: per
    CPI the power within half a spacing of the line over the noise power there (the
    flight's far floor ``M.floor``, at which the model's noise is drawn;
    :func:`line_band_snr`: a line, its skirt and whatever folds there); over the CPIs
    its median and that median's confidence bounds (the CPIs' robust scatter, at
    ``cfg.line_false_alarm`` two-sided, Bonferroni over the lines; ``cfg`` default
    :class:`DiagnosisConfig`'s). A line is
    *present* where its lower bound is above zero, *absent* where it is not.

    - ``model_only`` (where the calibration fitted the lines' fall-off, on at least
      two usable harmonics): the model's line is present, the recording's absent, and the
      model's median stands at least ``cfg.model_clear_snr_db`` over the noise and
      ``margin_db`` above the recording's upper bound, and the model's level holds
      (within ``margin_db``) at one of the two nearest lines on that side that both
      hold (the model puts a line where the recording has none).
    - ``recording_only``: the recording's line is present, the model's absent, and the
      recording's median stands ``margin_db`` above the model's upper bound and above
      what thin-wire blades of the declared length could put there (``wire_power``:
      one blade's power per rotation harmonic,
      :func:`~microdoppler.causes.measure.thin_wire_line_power`, scaled to the
      recording's own lines within the tips' extent, without the alpha envelope,
      which only lowers it): a line beyond the declared tips' Doppler extent.

    The model's lines reach the tips' Doppler extent of the declared carrier, blade
    length, blade count and rotation rate and no further, so a wrong set-up moves its
    lines away from the recording's. Lines within the clutter guard, on the body's
    band or at the Nyquist edge are not read.

    Returns a dict: ``lines`` (every line read: ``order``, ``side``, ``band_hz``
    body-relative, ``measured_snr_db`` and ``model_snr_db`` (medians), ``measured`` and
    ``model`` (``present``/``absent``)), ``missing`` (the misfits, each with its
    ``direction``) and ``z`` (the bounds' quantile)."""
    st = M.stft
    B = int(M.info["n_blades"])
    dil = np.where(np.isfinite(M.dil), M.dil, np.nanmedian(M.dil) if np.isfinite(M.dil).any() else 1.0)
    h_meas = B * M.f_log_hz * dil
    nyq = float(st.f_hz[-1])
    use = np.flatnonzero(M.valid)
    h_med = float(np.median(h_meas[use])) if len(use) else np.nan
    empty = {"lines": [], "missing": [], "z": None}
    if not len(use) or not np.isfinite(h_med) or h_med <= 0:
        return empty
    n_max = int(np.floor(2 * nyq / h_med)) + 1
    rows = []
    for n in range(1, n_max + 1):
        for side in (1, -1):
            snr = np.full((2, len(use)), np.nan)
            for j, i in enumerate(use):
                for k, (spec, fb, h) in enumerate(
                    ((st, M.f_body_hz[i], h_meas[i]), (sim, f_sim_hz[i], spacing_sim_hz[i]))
                ):
                    fc = fb + side * n * h
                    if abs(fc) + h / 2 > nyq or abs(fc) < guard + h / 2 or (n - 0.5) * h < body_half:
                        continue
                    snr[k, j] = line_band_snr(spec, i, fc, h, M.floor[i])
            ok = np.isfinite(snr).all(axis=0)
            if ok.sum() >= 6:
                rows.append((n, side, snr[:, ok]))
    if not rows:
        return empty
    cfg = DiagnosisConfig() if cfg is None else cfg
    z = float(norm.isf(cfg.line_false_alarm / (2 * 2 * len(rows))))
    med = np.array([np.median(r[2], axis=1) for r in rows])  # [n_rows, 2]: measured, model
    mad = np.array([np.median(np.abs(r[2] - np.median(r[2], axis=1, keepdims=True)), axis=1) for r in rows])
    n_c = np.array([r[2].shape[1] for r in rows])
    se = _MEDIAN_EFF * 1.4826 * mad / np.sqrt(n_c)[:, None]
    lo, hi = med - z * se, med + z * se
    present = lo > 0
    gain = 10 ** (margin_db / 10)
    clear = 10 ** (cfg.model_clear_snr_db / 10)
    # the model's lines are a prediction only where the calibration fitted their fall-off
    # (the alpha envelope, on two usable harmonics or more); on one, alpha is taken as
    # 0 and every line out to the tips is an extrapolation, not a prediction
    fitted = M.calib is not None and M.calib.n_usable_harmonics >= 2
    # what thin-wire blades of the declared length could put at each order: the
    # recording's own lines scaled by one blade's rotation-harmonic powers (no envelope)
    bound = np.full(len(rows), np.inf)
    if wire_power is not None:
        orders = np.array([r[0] for r in rows])
        k = np.minimum(orders * B, len(wire_power) - 1)
        wp = np.maximum(wire_power[k], 1e-300)
        # anchored on the recording's lines within the tips' extent (one blade's power
        # within 20 dB of its strongest harmonic there)
        anchor = present[:, 0] & (wp >= 1e-2 * float(np.max(wire_power[B::B] if len(wire_power) > B else wp)))
        seen = np.where(anchor, np.maximum(med[:, 0], 0.0), 0.0)
        for j in range(len(rows)):
            bound[j] = float(np.max(seen * wp[j] / wp)) if anchor.any() else np.inf
    both = present[:, 0] & present[:, 1]

    def anchored(j: int) -> bool:
        """The model's level holds next to line ``j``: within ``margin_db`` of the
        recording's at one of the two nearest lines (same side) that both hold. Where
        it misses the lines the recording holds (an envelope that falls faster than the
        calibrated one), its lines beyond are that misfit of level, not lines where
        the recording has none."""
        near = [m for m in range(len(rows)) if both[m] and rows[m][1] == rows[j][1]]
        near = sorted(near, key=lambda m: abs(rows[m][0] - rows[j][0]))[:2]
        return any(abs(DB * np.log(med[m, 1] / med[m, 0])) <= margin_db for m in near)

    lines, missing = [], []
    for j, (n, side, _) in enumerate(rows):
        row = {
            "order": int(n),
            "side": "upper" if side > 0 else "lower",
            "band_hz": sorted([round(side * (n - 0.5) * h_med, 1), round(side * (n + 0.5) * h_med, 1)]),
            "measured_snr_db": round(float(DB * np.log(max(med[j, 0], 1e-3))), 1),
            "model_snr_db": round(float(DB * np.log(max(med[j, 1], 1e-3))), 1),
            "measured": "present" if present[j, 0] else "absent",
            "model": "present" if present[j, 1] else "absent",
        }
        lines.append(row)
        if (
            fitted
            and present[j, 1]
            and not present[j, 0]
            and med[j, 1] >= max(clear, gain * max(hi[j, 0], 0.0))
            and anchored(j)
        ):
            missing.append({**row, "direction": "model_only"})
        elif present[j, 0] and not present[j, 1] and med[j, 0] >= gain * max(hi[j, 1], bound[j]):
            missing.append({**row, "direction": "recording_only"})
    return {"lines": lines, "missing": missing, "z": round(z, 2)}


#: the declared fields a misfit of the lines' extent or comb points at
SUSPECT_FIELDS = "prf_hz, carrier_hz, n_blades, blade_length_m"


def missing_reason(missing: list) -> str:
    """The direction of the two-sided check's misfits, in words ("" when none)."""
    out = []
    if any(b["direction"] == "model_only" for b in missing):
        out.append("the model puts lines where the recording has none")
    if any(b["direction"] == "recording_only" for b in missing):
        out.append("the recording holds lines the model lacks")
    return f"{'; '.join(out)}: check {SUSPECT_FIELDS}" if out else ""


def _block_means(d, fold, block, blocks):
    """Per band of ``d`` [n_cpi, n_bands]: the mean over the blocks of CPIs of each
    block's mean (``mu``), the blocks that hold it (``nb``), its standard error from
    the blocks' scatter (``se``) and each fold's mean (``mf``, two arrays)."""
    import warnings

    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        Db = np.array([np.nanmean(d[block == k], axis=0) for k in blocks])  # [n_blocks, n_bands]
        fb = np.array([fold[block == k][0] for k in blocks])
        mu = np.nanmean(Db, axis=0)
        nb = np.sum(np.isfinite(Db), axis=0)
        se = np.nanstd(Db, axis=0, ddof=1) / np.sqrt(np.maximum(nb, 1))
        mf = [np.nanmean(Db[fb == k], axis=0) for k in (0, 1)]
    return mu, nb, se, mf


def _band_test(j, mu, nb, se, mf, level: float, margin_db: float) -> tuple[bool, bool, bool]:
    """Band ``j``: (its mean residual significant by Student's t over the blocks at
    ``level``; of one sign in both folds; flagged: significant, at least ``margin_db``
    and at least half of it, of that sign, in each fold)."""
    sig = abs(mu[j]) / se[j] > student_t.isf(level, df=nb[j] - 1)
    one_sign = all(np.isfinite(m[j]) and np.sign(m[j]) == np.sign(mu[j]) for m in mf)
    same = all(np.isfinite(m[j]) and np.sign(m[j]) == np.sign(mu[j]) and abs(m[j]) >= margin_db / 2 for m in mf)
    return bool(sig), bool(one_sign), bool(abs(mu[j]) >= margin_db and sig and same)


def goodness_of_fit(flight, M: Measurements, D: Decision, cfg: DiagnosisConfig) -> dict:
    """Held-out residual of the measured spectrogram against the model with every
    named cause's extension (:func:`simulate_flight`, with the flight's background).

    Both spectrograms are read relative to their own body Doppler in bands of half
    the rotation rate (so lines and the gaps between them fall in separate bands), up
    to half a line spacing beyond the highest harmonic the calibration used (beyond
    it the envelope is extrapolated, not fitted); the body's band (S_body's
    calibration; with a fluctuating body named, the bands beside it too) and the
    clutter line's skirt (twice the clutter notch, three times without a background
    recording, twice the phase-noise band when phase noise is named, and then the
    edge of the body's skirt too, 75-450 Hz from it: a 1/f-like skirt reaches that far) are left out. Per band, the residual is
    10 log10 of measured over model mean power, averaged over blocks of
    ``block_cpis`` CPIs; its standard error comes from the blocks' scatter (fading and
    noise included). A band is ``excess`` when ``|residual| >= margin_excess_db``,
    ``|residual| / se`` beats Student's t (blocks - 1 degrees of freedom) at the two-sided Bonferroni level ``alpha / n_bands``, and
    each fold's mean has the same sign and at least half the margin.

    Two-sided over the whole Doppler band (:func:`line_presence`): a HERM line the
    model puts clearly above the noise where the recording has none, or one the
    recording holds beyond the declared tips' extent where the model has none, makes
    the flight ``unexplained`` too, with the direction and the declared fields to
    check (:func:`missing_reason`).

    Returns a dict: ``excess`` (bool: a band or a line misfits), ``excess_db`` and
    ``band_hz`` (the worst band, body-relative [Hz]; without an excess band, the line's
    level difference, measured minus model [dB], and its band), ``bands`` (every excess
    band), ``missing`` (every line on one side only), ``missing_reason`` (its direction
    and the fields to check, "" when none), ``lines_read``, ``lines_z``, ``n_bands``, ``n_blocks``,
    ``max_abs_residual_db`` (the largest band residual, excess or not),
    ``largest_significant_db`` (the largest that is significant and of one sign in
    both folds, whatever its size: what a smaller margin would have flagged) and
    ``margin_db``."""
    st = M.stft
    prf = flight.prf_hz
    ext = named_extensions(D)
    named = _named_specs(ext)
    # the model calibrated as the named causes ask (a blade imbalance: with its
    # rotation lines in the sidebands' floor model)
    M = _calibration_measurement(M, named)
    n_fft = cfg.cpi_pulses(prf)
    sim = stft_power(simulate_flight(flight, M, ext, cfg.seed, n_fft), prf, n_fft)
    f_sim = refine_peak(sim, body_doppler(flight, sim.t_s), cfg.body_search_hz)
    B = int(flight.attrs["n_blades"])
    dil = np.where(np.isfinite(M.dil), M.dil, 1.0)
    f_rot = float(np.median(M.f_log_hz * dil))
    bw = f_rot / 2
    # the region the calibrated model speaks for: up to half a spacing beyond the
    # highest harmonic the calibration used (beyond it the envelope is extrapolated),
    # without the body line (its level is S_body's calibration)
    usable = np.flatnonzero(M.usable_pairs)
    n_top = int(M.harm[usable[-1]]) if len(usable) else 1
    n_side = int(np.floor((n_top + 0.5) * B * f_rot / bw))
    n_bands = 2 * n_side + 1
    # the clutter line's skirt (wind-blown clutter differs between the flight and its
    # background recording), wider without a background; with phase noise named, its
    # whole skirt band (the catalog's flat skirt need not have the measured shape)
    guard = cfg.clutter_guard_hz * (2.0 if flight.background_iq is not None else 3.0)
    skirt_edge = None
    for spec in named:  # a named phase noise: its whole skirt band and the edge of the body's skirt
        guard, edge = spec.gof_guard(guard)
        skirt_edge = edge if edge is not None else skirt_edge
    # the body's band (its level is S_body's calibration); with a fluctuating body
    # named, its neighbours too (the fluctuation's skirt scales with the body line,
    # which the model draws with the blades' mean return added)
    body_half = bw / 2
    for spec in named:
        half = spec.gof_body_half(bw)
        body_half = half if half is not None else body_half
    use = np.flatnonzero(M.valid)
    d = np.full((len(st.t_s), n_bands), np.nan)
    for i in use:
        d[i] = DB * np.log(
            band_power(st, i, M.f_body_hz[i], bw, n_side, guard, body_half, skirt_edge)
            / band_power(sim, i, f_sim[i], bw, n_side, guard, body_half, skirt_edge)
        )
    fold = folds(len(st.t_s), cfg.block_cpis)
    block = np.arange(len(st.t_s)) // cfg.block_cpis
    blocks = np.unique(block[use])
    mu, nb, se, mf = _block_means(d, fold, block, blocks)
    # the blocks' own scatter is the yardstick: Student's t with (blocks - 1) degrees
    # of freedom per band, two-sided, Bonferroni over the bands
    level = cfg.alpha / (2 * n_bands)
    z_crit = float(student_t.isf(level, df=max(int(np.median(nb[nb > 1])) - 1, 1))) if np.any(nb > 1) else np.inf
    centres = (np.arange(n_bands) - n_side) * bw
    flagged = []
    largest_sig = 0.0  # the largest residual that is significant and of one sign in both folds, any size
    for j in range(n_bands):
        if nb[j] < 4 or not np.isfinite(mu[j]) or not np.isfinite(se[j]) or se[j] <= 0:
            continue
        sig, one_sign, flag = _band_test(j, mu, nb, se, mf, level, cfg.margin_excess_db)
        if sig and one_sign:
            largest_sig = max(largest_sig, float(abs(mu[j])))
        if flag:
            flagged.append(
                {
                    "band_hz": [round(float(centres[j] - bw / 2), 2), round(float(centres[j] + bw / 2), 2)],
                    "excess_db": round(float(mu[j]), 2),
                    "z": round(float(mu[j] / se[j]), 1),
                }
            )
    fin = np.isfinite(mu)
    worst = max(flagged, key=lambda b: abs(b["excess_db"])) if flagged else None
    # the other way round too, over the whole Doppler band: a line the model puts where
    # the recording has none, or one the recording holds that the model lacks
    presence = line_presence(
        M,
        sim,
        f_sim,
        model_spacing_hz(M, ext),
        guard=guard,
        body_half=body_half,
        margin_db=cfg.margin_excess_db,
        wire_power=thin_wire_line_power(
            float(flight.attrs["blade_length_m"]), flight.wavelength_m, int(prf / max(f_rot, 1e-6)) + 2 * B
        ),
        cfg=cfg,
    )
    missing = presence["missing"]
    if worst is None and missing:
        first = max(missing, key=lambda b: abs(b["measured_snr_db"] - b["model_snr_db"]))
        worst = {"excess_db": round(first["measured_snr_db"] - first["model_snr_db"], 2), "band_hz": first["band_hz"]}
    return {
        "excess": bool(flagged) or bool(missing),
        "excess_db": worst["excess_db"] if worst else None,
        "band_hz": worst["band_hz"] if worst else None,
        "bands": flagged,
        "missing": missing,
        "missing_reason": missing_reason(missing),
        "lines_read": len(presence["lines"]),
        "lines_z": presence["z"],
        "n_bands": int(fin.sum()),
        "n_blocks": int(len(blocks)),
        "z_threshold": round(z_crit, 2),
        "max_abs_residual_db": round(float(np.nanmax(np.abs(mu))), 2) if fin.any() else None,
        "largest_significant_db": round(largest_sig, 2),
        "margin_db": float(cfg.margin_excess_db),
        "analysed_band_hz": [round(float(centres[0] - bw / 2), 2), round(float(centres[-1] + bw / 2), 2)],
        "model": sorted(ext.effects) if ext is not None else [],
        "_residual_db": mu,
        "_band_centres_hz": centres,
        "_band_args": {"bw": bw, "n_side": n_side, "guard": guard, "body_half": body_half, "skirt_edge": skirt_edge},
    }


def plot_diagnosis(
    flight, M: Measurements, D: Decision, path, cfg: DiagnosisConfig, *, gof: dict | None = None
) -> Path:
    """Write the figure of ``flight``'s diagnosis (its measurement ``M``, decision
    ``D`` and goodness of fit ``gof``) to ``path`` (PNG, atomically); returns the path.

    Panels: measured; the paper's model (baseline); the model with every named
    cause's extension; its residual (measured - extended) with the unexplained bands
    marked; the statistic that named the first cause."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tests, cause = D.shown, D.cause
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    n_fft = cfg.cpi_pulses(flight.prf_hz)
    base_iq = simulate_flight(flight, M, None, cfg.seed, n_fft)
    ext = named_extensions(D)
    # calibrated as the goodness of fit calibrates it (with a named imbalance's lines)
    Me = _calibration_measurement(M, _named_specs(ext))
    ext_iq = simulate_flight(flight, Me, ext, cfg.seed, n_fft) if ext else base_iq
    named = " + ".join(sorted(ext.effects)) if ext is not None else "none"
    st = M.stft
    sb = stft_power(base_iq, flight.prf_hz, n_fft)
    se = stft_power(ext_iq, flight.prf_hz, n_fft) if ext else sb
    h = float(np.median(M.f_log_hz)) * int(flight.attrs["n_blades"])
    fc = float(np.median(M.f_body_hz))
    missing = (gof or {}).get("missing") or []
    # wide enough to show every line the two-sided check found on one side only
    reach = max([4.5 * h, *(max(abs(e) for e in b["band_hz"]) + 0.5 * h for b in missing)])
    sel = np.abs(st.f_hz - fc) <= reach
    f = st.f_hz[sel]
    ext_t = [st.t_s[0], st.t_s[-1], f[0], f[-1]]
    ref = DB * np.log(np.median(M.floor))
    fig, ax = plt.subplots(1, 5, figsize=(20, 5), constrained_layout=True)
    for a_, s_, title in (
        (ax[0], st, "measured"),
        (ax[1], sb, "baseline (paper model)"),
        (ax[2], se, f"extended ({named})"),
    ):
        im = a_.imshow(
            (DB * np.log(s_.p[:, sel] + 1e-30) - ref).T,
            origin="lower",
            aspect="auto",
            extent=ext_t,
            vmin=-5,
            vmax=45,
            cmap="viridis",
        )
        a_.set_title(title)
        a_.set_xlabel("time [s]")
    ax[0].set_ylabel("Doppler [Hz]")
    fig.colorbar(im, ax=ax[2], label="dB over floor")
    res = DB * np.log((st.p[:, sel] + 1e-30) / (se.p[:, sel] + 1e-30))
    im2 = ax[3].imshow(res.T, origin="lower", aspect="auto", extent=ext_t, vmin=-10, vmax=10, cmap="RdBu_r")
    ax[3].set_title("residual: measured - extended [dB]")
    for band in (gof or {}).get("bands", []):
        for edge in band["band_hz"]:
            ax[3].axhline(fc + edge, color="k", lw=0.8, ls="--")
    # the two-sided check's lines: shaded on the residual, bracketed on the measured and
    # the extended (magenta: the model's lines where the recording has none; orange:
    # the recording's lines the model lacks)
    for band in missing:
        colour = "m" if band["direction"] == "model_only" else "orange"
        ax[3].axhspan(fc + band["band_hz"][0], fc + band["band_hz"][1], color=colour, alpha=0.35, lw=0)
        for a_ in (ax[0], ax[2]):
            for edge in band["band_hz"]:
                a_.axhline(fc + edge, color=colour, lw=1.2, ls=":")
    if gof and gof.get("excess"):
        how = (
            f"{gof['excess_db']:+.1f} dB in {gof['band_hz'][0]:+.0f}..{gof['band_hz'][1]:+.0f} Hz (dashed)"
            if gof.get("bands")
            else f"{len(missing)} line band(s) on one side only (shaded)"
        )
        why = f"\n{gof['missing_reason']}" if gof.get("missing_reason") else ""
        ax[3].set_title(f"residual: measured - extended [dB]\nunexplained: {how}{why}", fontsize=8)
    ax[3].set_xlabel("time [s]")
    fig.colorbar(im2, ax=ax[3])
    show = (
        cause
        if cause != "none"
        else max((t for t in tests.values() if t.testable), key=lambda t: t.log_e, default=None)
    )
    show = tests[show] if isinstance(show, str) else show
    if show is not None and show.series:
        registry.get(show.cause).draw_panel(ax[4], show)  # the cause's own panel
    ax[4].set_title(
        f"{show.cause if show else ''}: {show.statistic if show else ''}\nlog e-value {show.log_e:.1f}"
        if show
        else "no statistic",
        fontsize=9,
    )
    ax[4].set_xlabel("time [s]")
    shown = [c["cause"] for c in D.entry["causes"]] + (["unexplained"] if gof and gof.get("excess") else [])
    fig.suptitle(f"{flight.flight_id}: diagnosis = {', '.join(shown) or 'none'}")
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=80)
    plt.close(fig)
    tmp.replace(path)
    return path


def _named_specs(ext) -> list:
    """The registered causes named in ``ext`` (an ExtensionSet or None), in order."""
    return [] if ext is None else [s for s in registry.specs() if s.name in ext.effects]


def _calibration_measurement(M, named):
    """``M`` as the named causes ask the model to be calibrated on."""
    for spec in named:
        M = spec.calibration_measurement(M)
    return M
