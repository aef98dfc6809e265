"""Step 4 of the diagnosis: what the named causes explain, and what they leave.

:func:`goodness_of_fit` compares the measured spectrogram with the calibrated paper's
model extended by every named cause, band by band relative to the body Doppler: a
band whose residual exceeds what the flight's own scatter allows (significant,
replicated in both folds, at least ``margin_excess_db``) makes the flight
``unexplained``, so that ``none`` always means that the model fits.
:func:`plot_diagnosis` shows the measured spectrogram, the baseline, the model with
every named cause's extension, its residual with the unexplained band marked, and the
statistic that named the first cause (or the strongest test when none was named)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy.fft as sfft
from scipy.stats import t as student_t

from ..causes import registry
from ..causes.extensions import ExtensionSet
from ..synthesis.model import ModelExtensions, Track, add_noise

from .config import BODY_SEARCH_HZ, DiagnosisConfig
from .decide import Decision
from .hypotheses import folds
from .measure import DB, Measurements, body_doppler, refine_peak, simulate_blades, stft_power


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

    Returns a dict: ``excess`` (bool), ``excess_db`` and ``band_hz`` (the worst band,
    body-relative [Hz]), ``bands`` (every excess band), ``n_bands``, ``n_blocks``,
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
    f_sim = refine_peak(sim, body_doppler(flight, sim.t_s), BODY_SEARCH_HZ)
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
    return {
        "excess": bool(flagged),
        "excess_db": worst["excess_db"] if worst else None,
        "band_hz": worst["band_hz"] if worst else None,
        "bands": flagged,
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
    sel = np.abs(st.f_hz - fc) <= 4.5 * h
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
    if gof and gof.get("excess"):
        ax[3].set_title(
            f"residual: measured - extended [dB]\nunexplained: {gof['excess_db']:+.1f} dB in "
            f"{gof['band_hz'][0]:+.0f}..{gof['band_hz'][1]:+.0f} Hz (dashed)",
            fontsize=9,
        )
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
