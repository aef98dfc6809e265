"""Per-CPI statistics of one measured drone flight against the paper's model of it.

:func:`measure` returns a :class:`Measurements` with, per CPI: the body Doppler and
power, the HERM line spacing measured by matching the measured spectrum to the
model's (a frequency dilation ``s_t`` of the model's line pattern), the power of each
upper and lower sideband (noise-subtracted, with a validity mask that drops
sidebands on a raised floor, e.g. near clutter), the model's prediction of each, and
the near-clutter floor (flight and background) for the phase-noise test.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..io.motorlog import MotorLog
from .features import (DB, Stft, band_power, body_doppler, cpi_average, local_floor, noise_power_factor,
                       refine_peak, simulate_blades, stft_power)


@dataclass
class Measurements:
    """Per-CPI statistics (arrays [n_t] unless noted)."""

    t_s: np.ndarray
    valid: np.ndarray            # bool: CPI usable (body clear of clutter, no artifact, within the log)
    f_body_hz: np.ndarray
    body_pow: np.ndarray         # noise-subtracted body power (periodogram units)
    body_sd_db: np.ndarray       # noise std of 10 log10 body_pow (floor at the body: body_floor_ratio)
    floor: np.ndarray            # far noise floor per bin
    range_m: np.ndarray
    f_log_hz: np.ndarray         # CPI-average of the log's mean motor speed [rev/s]
    dil: np.ndarray              # measured / model line spacing
    dil_ok: np.ndarray           # bool
    harm: np.ndarray             # harmonic numbers used [N]
    up: np.ndarray               # [n_t, N] upper sideband power (noise-subtracted)
    lo: np.ndarray               # [n_t, N] lower
    up_sd: np.ndarray            # [n_t, N] noise std (linear)
    lo_sd: np.ndarray
    pair_ok: np.ndarray          # [n_t, N] bool
    model_h: np.ndarray          # [n_t, N] model (alpha=0, S_blade=1) sideband power, mean of +-n
    log: MotorLog = None
    stft: Stft = None
    bg_stft: Stft | None = None
    sim_stft: Stft | None = None  # the model's blades (alpha = 0, S_blade = 1), body-relative
    info: dict = field(default_factory=dict)
    body_fine: dict | None = None  # short-window body power series (see body_power_fine)
    side_fine: dict | None = None  # short-window sideband power per harmonic (see sideband_power_fine)


def _dilation(st: Stft, sim: Stft, f_body, h0, n_harm, s_grid, floor, clutter_hz):
    """Per-CPI dilation of the model's body-relative blade pattern that best matches
    the measured one (normalised correlation of clipped dB spectra)."""
    n_t = st.p.shape[0]
    df = st.bin_hz
    out = np.full(n_t, np.nan)
    q = np.full(n_t, 0.0)
    for i in range(n_t):
        dmax = (n_harm + 0.5) * h0[i] * s_grid[-1]
        dmin = 0.5 * h0[i] * s_grid[0]
        deltas = np.arange(-dmax, dmax + df, df)
        deltas = deltas[np.abs(deltas) > dmin]
        fm = f_body[i] + deltas
        keep = (np.abs(fm) > clutter_hz) & (np.abs(fm) < st.f_hz[-1])
        deltas, fm = deltas[keep], fm[keep]
        if len(deltas) < 20:
            continue
        m = np.interp(fm, st.f_hz, st.p[i])
        lm = np.clip(DB * np.log(m / floor[i] + 1e-12), 0, 40)
        lm -= lm.mean()
        sp = sim.p[i]
        ref = sp.max()
        ls_full = np.clip(DB * np.log(sp / ref + 1e-12) + 50, 0, 50)
        arg = deltas[None, :] / s_grid[:, None]
        ls = np.interp(arg, sim.f_hz, ls_full)
        ls -= ls.mean(axis=1, keepdims=True)
        num = ls @ lm
        den = np.sqrt((ls ** 2).sum(axis=1) * (lm ** 2).sum()) + 1e-12
        c = num / den
        j = int(np.argmax(c))
        if 0 < j < len(s_grid) - 1:
            a, b, cc = c[j - 1], c[j], c[j + 1]
            d = 0.5 * (a - cc) / (a - 2 * b + cc) if (a - 2 * b + cc) < 0 else 0.0
            out[i] = s_grid[j] + np.clip(d, -0.5, 0.5) * (s_grid[1] - s_grid[0])
        else:
            out[i] = s_grid[j]
        q[i] = c[j]
    return out, q


def body_floor_ratio(st: Stft, f_body_hz: np.ndarray, spacing_hz: np.ndarray, cfg,
                     smooth_cpis: int = 2) -> np.ndarray:
    """Floor at the body's distance from the clutter line relative to the far noise
    floor, per CPI (>= 1) [n_t]: the median / ln 2 of the bins whose |f| is within
    ``3 body_half_hz`` of |f_b| (both sides of the clutter line), off the target
    (farther than ``body_half_hz + pn_body_guard_hz`` from the body and than
    ``pn_line_guard_frac`` x the HERM spacing ``spacing_hz`` [n_t] from its lines,
    as in the phase-noise test) and off the clutter line (``clutter_guard_hz``),
    over the median / ln 2 of the whole spectrum; within ``6 body_half_hz`` when
    fewer than 4 bins qualify, 1 when still fewer; averaged over +-``smooth_cpis``.

    The body's band holds, besides the body, whatever random floor lies there: the
    thermal noise, and near the clutter line the wind-blown clutter's skirt (10-20 dB
    above the thermal floor at 20-50 Hz on radar 2's site) and the skirt a radar's
    phase noise spreads around the clutter line (about +20 dB at 100 Hz for 0.008 rad
    rms on radar 1, case 111 of tests/test_diagnosis.py). Both are random processes:
    they scatter the band's power like a raised floor, which the far floor does not
    show (body SNR 21-36 dB flights near the clutter named a white body_fluctuation).
    Both are functions of the distance from the clutter line, so they are read at
    the body's distance, off the body's own skirt (a fast fluctuation spreads its
    line: 4.5 dB at 0.08 s raises the bins next to the band ~15 dB at 44 dB SNR) and
    off the blade lines, which are no floor."""
    n_t = len(f_body_hz)
    far = np.median(st.p, axis=1) / np.log(2.0)
    f = st.f_hz
    half = cfg.body_half_hz
    clear = np.abs(f) > cfg.clutter_guard_hz
    r = np.ones(n_t)
    for i in range(n_t):
        fb, sp = f_body_hz[i], spacing_hz[i]
        keep = clear & (np.abs(f - fb) > half + cfg.pn_body_guard_hz)
        if np.isfinite(sp) and sp > 0:
            for n in range(1, 16):
                for sg in (1, -1):
                    keep &= np.abs(f - (fb + sg * n * sp)) > cfg.pn_line_guard_frac * sp
        dist = np.abs(np.abs(f) - abs(fb))
        for width in (3 * half, 6 * half):
            sel = keep & (dist <= width)
            if sel.sum() >= 4:
                if far[i] > 0:
                    r[i] = float(np.median(st.p[i, sel])) / np.log(2.0) / far[i]
                break
    k = np.ones(2 * smooth_cpis + 1)
    r = np.convolve(r, k, mode="same") / np.convolve(np.ones(n_t), k, mode="same")
    return np.maximum(r, 1.0)


#: short analysis windows of the body power series tried [pulses] (``n_fft / d``)
FINE_DIVISORS = (8, 4, 2)


def body_power_fine(iq, prf_hz: float, t_cpi: np.ndarray, f_body_hz: np.ndarray, valid_cpi: np.ndarray,
                    n_fft: int, range_t_s=None, range_m=None, min_fraction: float = 0.4,
                    floor_ratio: np.ndarray | None = None) -> dict:
    """Body power in short windows (Blackman-Harris, 50 % overlap): the body line is
    strong, so its power can be read far faster than the CPI and a fluctuation's
    correlation time resolved down to ~0.05 s.

    The window is the shortest of ``n_fft / FINE_DIVISORS`` for which at least
    ``min_fraction`` of the valid CPIs' windows hold the body clear of the clutter
    line: the stationary clutter is first removed by subtracting the moving average
    over one window (a notch at 0 Hz), and a window's body band (its nearest bin
    +-2 bins) must lie 2.5 bins + 10 Hz from 0 Hz.

    Returns a dict: ``t_s`` [m] window centres, ``y_db`` [m] 10 log10 of the
    noise-subtracted power of the body band (Doppler interpolated from the CPIs),
    ``noise_var_db2`` [m], ``valid`` [m] (the nearest CPI valid, the body clear of
    the clutter and its power > 3 noise std), ``window``, ``hop_s``, ``range_m`` [m],
    ``n_window`` [pulses].

    The noise of a window's band power is that of the floor around the body: the
    far floor times ``floor_ratio`` [n_cpi] (:func:`body_floor_ratio`, of the
    nearest CPI; default 1), through the window (:func:`.features.noise_power_factor`).
    """
    from scipy.ndimage import uniform_filter1d

    x0 = np.asarray(iq, np.complex128)
    out = None
    for d in FINE_DIVISORS:
        nw = max(64, n_fft // d)
        x = x0 - (uniform_filter1d(x0.real, nw, mode="nearest") + 1j * uniform_filter1d(x0.imag, nw, mode="nearest"))
        st = stft_power(x, prf_hz, nw)
        df = st.bin_hz
        fb = np.interp(st.t_s, t_cpi, f_body_hz)
        floor = np.median(st.p, axis=1) / np.log(2.0)
        jc = np.clip(np.round(st.at(fb)).astype(int), 2, len(st.f_hz) - 3)
        rows = np.arange(len(st.t_s))
        s = sum(st.p[rows, jc + k] for k in range(-2, 3))
        nb = 5.0
        pw = s - nb * floor
        near = np.clip(np.searchsorted(t_cpi, st.t_s), 0, len(t_cpi) - 1)
        fl = floor * (floor_ratio[near] if floor_ratio is not None else 1.0)
        var = noise_power_factor(st.window) * (2 * np.maximum(pw, 0) * fl + nb * fl ** 2)
        base = valid_cpi[near]
        ok = base & (pw > 3 * np.sqrt(var)) & (np.abs(fb) > 4.5 * df + 10.0)
        y = DB * np.log(np.maximum(pw, 1e-30))
        nv = (DB * np.sqrt(var) / np.maximum(pw, 1e-30)) ** 2
        r = np.interp(st.t_s, range_t_s, range_m) if range_m is not None else np.ones(len(st.t_s))
        out = {"t_s": st.t_s, "y_db": y, "noise_var_db2": nv, "valid": ok, "window": st.window,
               "hop_s": float(st.t_s[1] - st.t_s[0]) if len(st.t_s) > 1 else float(nw / prf_hz / 2),
               "range_m": r, "n_window": int(nw)}
        if ok.sum() >= min_fraction * max(base.sum(), 1):
            break
    return out


#: short analysis window of the sideband power series [pulses] (``n_fft / 2``)
SIDE_FINE_DIVISOR = 2


def sideband_power_fine(iq, prf_hz: float, t_cpi: np.ndarray, f_body_hz: np.ndarray, spacing_hz: np.ndarray,
                        harm: np.ndarray, spread: float, n_fft: int, range_t_s=None, range_m=None,
                        divisor: int = SIDE_FINE_DIVISOR) -> dict:
    """Each HERM harmonic cluster's sideband power in short windows (``n_fft /
    divisor`` pulses, Blackman-Harris, 50 % overlap), for the fading's correlation
    time: the CPI grid (a 0.6 s window every 0.3 s) leaves a 1-2 s fading's time
    uncertain by ~20 % over 180 s even to its exact likelihood; on a grid twice as
    fine (0.3 s windows every 0.16 s) the short lags, which carry most of the
    information on T, are seen.

    Per window and harmonic n, the power summed over the whole cluster band (all
    the rotors' lines; centre f_b +- n h, f_b the body Doppler and h the line
    spacing ``spacing_hz``, both interpolated from the CPIs; half width
    n h 2.5 ``spread`` + 3 bins, at most 0.45 h) minus the band's share of the
    window's far floor (median / ln 2), upper and lower side apart. In so short a
    window the rotors' lines (1-3 % apart) are not resolved: their power beats at
    the lines' difference frequencies (n x a few Hz), a nuisance that is
    independent between the harmonics (:func:`.causes.fading_estimate_fine`
    measures it where the fading cancels). Which harmonics and windows are used is
    left to the caller (the nearest CPI's validity). The stationary clutter is
    first taken out as in :func:`body_power_fine`.

    Returns a dict: ``t_s`` [m] window centres, ``up``, ``lo`` [m, N] noise-subtracted
    powers, ``up_sd``, ``lo_sd`` [m, N] their noise std (linear,
    :func:`.features.noise_power_factor`), ``inside`` [m, N] bool (both bands
    within the Nyquist band), ``cpi`` [m] index of the nearest CPI, ``window``,
    ``hop_s``, ``range_m`` [m], ``n_window`` [pulses].
    """
    from scipy.ndimage import uniform_filter1d

    x0 = np.asarray(iq, np.complex128)
    nw = max(64, n_fft // divisor)
    x = x0 - (uniform_filter1d(x0.real, nw, mode="nearest") + 1j * uniform_filter1d(x0.imag, nw, mode="nearest"))
    st = stft_power(x, prf_hz, nw)
    del x
    df = st.bin_hz
    nf = len(st.f_hz)
    m = len(st.t_s)
    fb = np.interp(st.t_s, t_cpi, f_body_hz)
    h = np.interp(st.t_s, t_cpi, spacing_hz)
    floor = np.median(st.p, axis=1) / np.log(2.0)
    cs = np.concatenate([np.zeros((m, 1)), np.cumsum(st.p, axis=1)], axis=1)
    rows = np.arange(m)
    kap = noise_power_factor(st.window)
    N = len(harm)
    out = {k: np.zeros((m, N)) for k in ("up", "lo", "up_sd", "lo_sd")}
    inside = np.ones((m, N), bool)
    for k, n in enumerate(np.asarray(harm, float)):
        w = np.minimum(n * h * 2.5 * spread + 3 * df, 0.45 * h)
        for key, sg in (("up", 1.0), ("lo", -1.0)):
            fc = fb + sg * n * h
            a = np.ceil(st.at(fc - w)).astype(int)
            b = np.floor(st.at(fc + w)).astype(int)
            ins = (a >= 0) & (b <= nf - 1) & (b >= a)
            a, b = np.clip(a, 0, nf - 1), np.clip(b, 0, nf - 1)
            nb = np.maximum(b - a + 1, 0)
            s = cs[rows, b + 1] - cs[rows, a]
            pw = s - nb * floor
            out[key][:, k] = pw
            out[key + "_sd"][:, k] = np.sqrt(kap * (2 * np.maximum(pw, 0) * floor + nb * floor ** 2))
            inside[:, k] &= ins
    near = np.clip(np.searchsorted(t_cpi, st.t_s), 0, len(t_cpi) - 1)
    prev = np.clip(near - 1, 0, len(t_cpi) - 1)
    near = np.where(np.abs(t_cpi[prev] - st.t_s) < np.abs(t_cpi[near] - st.t_s), prev, near)
    r = np.interp(st.t_s, range_t_s, range_m) if range_m is not None else np.ones(m)
    out.update({"t_s": st.t_s, "inside": inside, "cpi": near, "window": st.window,
                "hop_s": float(st.t_s[1] - st.t_s[0]) if m > 1 else float(nw / prf_hz / 2),
                "range_m": r, "n_window": int(nw)})
    return out


def measure(flight, log: MotorLog, cfg) -> Measurements:
    """Measure the per-CPI statistics of ``flight`` (see module doc)."""
    prf = flight.prf_hz
    a = flight.attrs
    n_fft = cfg.n_fft
    iq = flight.iq
    st = stft_power(iq, prf, n_fft)
    n_t = len(st.t_s)
    df = st.bin_hz
    floor = np.median(st.p, axis=1) / np.log(2.0)
    # artifact CPIs: floor far above the flight's typical floor
    art = DB * np.log(floor / np.median(floor)) > cfg.artifact_floor_db
    # body
    f_trk = body_doppler(flight, st.t_s)
    f_body = refine_peak(st, f_trk, cfg.body_search_hz)
    body_valid = np.abs(f_body) > cfg.clutter_guard_hz + cfg.body_half_hz
    body_pow = np.empty(n_t)
    body_nb = np.empty(n_t)
    for i in range(n_t):
        s, body_nb[i] = band_power(st.p[i], st, f_body[i], cfg.body_half_hz)
        body_pow[i] = s - body_nb[i] * floor[i]
    # the paper's model (blades only, body-relative, alpha = 0)
    sim_iq, rev = simulate_blades(log, len(iq), prf, wavelength_m=flight.wavelength_m, n_blades=int(a["n_blades"]),
                                  blade_length_m=float(a["blade_length_m"]), n_fft=n_fft, seed=cfg.seed)
    sim = stft_power(sim_iq, prf, n_fft)
    t_fine = np.arange(rev.shape[0]) / prf
    step = max(1, int(prf / 200))
    f_log = cpi_average(t_fine[::step], rev[::step].mean(axis=1), st.t_s, st.window, prf)
    spread = float(np.clip(np.median(rev.std(axis=1) / np.maximum(rev.mean(axis=1), 1e-6)), 0, 0.1))
    B = int(a["n_blades"])
    h0 = B * f_log
    s_grid = np.arange(cfg.scale_min, cfg.scale_max + 1e-9, cfg.scale_step)
    dil, q = _dilation(st, sim, f_body, h0, cfg.n_match_harmonics, s_grid, floor, cfg.clutter_guard_hz)
    dil_ok = np.isfinite(dil) & (q > cfg.min_match) & ~art
    dil_f = np.where(np.isfinite(dil), dil, np.nanmedian(dil) if np.isfinite(dil).any() else 1.0)
    # the random part of the body band's power: the floor at the body's distance from
    # the clutter line, off the target (body_floor_ratio), through the window
    # (noise_power_factor)
    fl_ratio = body_floor_ratio(st, f_body, h0 * dil_f, cfg)
    fl_body = floor * fl_ratio
    var = noise_power_factor(st.window) * (2 * np.maximum(body_pow, 0) * fl_body + body_nb * fl_body ** 2)
    body_sd = DB * np.sqrt(var) / np.maximum(body_pow, 1e-30)
    # sidebands
    N = cfg.n_harmonics
    harm = np.arange(1, N + 1)
    up = np.zeros((n_t, N)); lo = np.zeros((n_t, N))
    up_sd = np.zeros((n_t, N)); lo_sd = np.zeros((n_t, N))
    ok = np.zeros((n_t, N), bool)
    model_h = np.zeros((n_t, N))
    nyq = st.f_hz[-1]
    for i in range(n_t):
        h = h0[i] * dil_f[i]
        hs = h0[i]
        for k, n in enumerate(harm):
            w = max(cfg.line_half_bins * df, n * h * 2.5 * spread + 2 * df)
            w = min(w, 0.4 * h)
            sides = []
            for sgn in (1, -1):
                fc = f_body[i] + sgn * n * h
                if abs(fc) + w > nyq:
                    sides.append(None)
                    continue
                s, nb = band_power(st.p[i], st, fc, w)
                fl = local_floor(st.p[i], st, fc, w, 0.5 * h)
                sides.append((s, nb, fl, fc))
            # model
            ms = [band_power(sim.p[i], sim, sg * n * hs, w)[0] for sg in (1, -1)]
            model_h[i, k] = 0.5 * (ms[0] + ms[1])
            if any(x is None for x in sides):
                continue
            good = True
            for j, (s, nb, fl, fc) in enumerate(sides):
                if not np.isfinite(fl) or DB * np.log(fl / floor[i]) > cfg.raised_floor_db \
                        or abs(fc) < cfg.clutter_guard_hz + w:
                    good = False
                pw = s - nb * fl
                sd = np.sqrt(2 * max(pw, 0) * fl + nb * fl ** 2)
                if j == 0:
                    up[i, k], up_sd[i, k] = pw, sd
                else:
                    lo[i, k], lo_sd[i, k] = pw, sd
            ok[i, k] = good and not art[i]
    bg = stft_power(flight.background_iq, prf, n_fft) if flight.background_iq is not None else None
    rng_m = np.interp(st.t_s, flight.track_time_s, flight.track_range_m)
    # CPIs outside the motor log's span: the log's speeds there are unknown
    in_log = (st.t_s >= log.time_s[0]) & (st.t_s <= log.time_s[-1])
    valid = body_valid & ~art & in_log
    fine = body_power_fine(iq, prf, st.t_s, f_body, valid, n_fft, flight.track_time_s, flight.track_range_m,
                           floor_ratio=fl_ratio)
    side_fine = sideband_power_fine(iq, prf, st.t_s, f_body, h0 * dil_f, harm, spread, n_fft,
                                    flight.track_time_s, flight.track_range_m)
    return Measurements(st.t_s, valid, f_body, body_pow, body_sd, floor, rng_m, f_log, dil, dil_ok, harm,
                        up, lo, up_sd, lo_sd, ok, model_h, log=log, stft=st, bg_stft=bg, sim_stft=sim,
                        info={"spread": spread, "prf_hz": prf, "n_blades": B, "n_artifact_cpis": int(art.sum()), "match_q": float(np.nanmedian(q))},
                        body_fine=fine, side_fine=side_fine)
