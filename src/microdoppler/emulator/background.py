"""Backgrounds: urban clutter, thermal noise, the radar's phase noise and artifacts.

The recorded sequence is the concatenation of the resolution cells (80 m range by
4 deg azimuth) the tracker assigns the target to. Each cell of a radar's site has a
fixed stationary clutter-to-noise ratio and phase (buildings), drawn from the site
seed, plus a wind-blown part (vegetation) whose power and Doppler spread grow with
the wind (exponential-like spectrum of width ``0.3 + 0.5 * wind`` Hz). Cell changes
cross-fade over :data:`CELL_FADE_S`. Thermal noise has unit power per pulse, so
every amplitude in the emulator is relative to it. ``background/iq`` records the same
cell sequence at another (target-free) time: same stationary clutter, new wind-blown
clutter, noise, phase noise and artifacts, and no phase-noise knob.

SNR model: ``snr_db`` of a target is its body line's peak over the median floor
expected from the pipeline's spectrogram in thermal noise alone,
``snr_db = snr_pulse_db + 10 log10(PG) + 10 log10(1 / ln 2)`` with PG the processing
gain (sum w)^2 / sum w^2 of the 4096-point Blackman-Harris window and 1/ln 2 the
ratio of the mean to the median of the exponential noise power.
"""

from __future__ import annotations

import numpy as np
import scipy.fft as sfft

from ..spectra.periodogram import window
from .knobs import band_limited_phase
from .radars import RadarSite

RANGE_CELL_M = 80.0
AZ_CELL_DEG = 4.0
CELL_FADE_S = 0.2


def stft_gain_db(n_fft: int = 4096) -> float:
    """dB from per-pulse SNR to the expected spectrogram line-over-median-floor SNR."""
    w = window(n_fft)
    return float(10 * np.log10(w.sum() ** 2 / (w**2).sum()) + 10 * np.log10(1 / np.log(2)))


def pulse_amplitude(snr_db: float, n_fft: int = 4096) -> float:
    """Amplitude per pulse (noise power 1) of a line of spectrogram SNR ``snr_db``."""
    return float(10 ** ((snr_db - stft_gain_db(n_fft)) / 20))


def cell_ids(range_m: np.ndarray, azimuth_rad: np.ndarray) -> np.ndarray:
    """Resolution cell (range index, azimuth index) per sample: int64 [n, 2]."""
    return np.column_stack([np.floor(range_m / RANGE_CELL_M), np.floor(np.rad2deg(azimuth_rad) / AZ_CELL_DEG)]).astype(
        np.int64
    )


def _cell_clutter(site: RadarSite, site_seed: int, cell) -> tuple[float, float]:
    rng = np.random.default_rng([site_seed, int(site.radar_id[-1]), int(cell[0]) + 10_000, int(cell[1]) + 1000])
    lo, hi = site.clutter_cnr_db
    return float(rng.uniform(lo, hi)), float(rng.uniform(0, 2 * np.pi))


def clutter_envelope(t_track_s, cells, t_s, site: RadarSite, site_seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Stationary clutter (complex64 [n]) and its amplitude (float32 [n]) at pulse
    times ``t_s`` for the cell sequence ``cells`` sampled at ``t_track_s``."""
    uniq = {}
    vals = np.empty(len(cells), np.complex128)
    for i, c in enumerate(map(tuple, cells)):
        if c not in uniq:
            cnr, ph = _cell_clutter(site, site_seed, c)
            uniq[c] = 10 ** (cnr / 20) * np.exp(1j * ph)
        vals[i] = uniq[c]
    # cross-fade: smooth the piecewise-constant sequence with a CELL_FADE_S window
    dt = float(np.median(np.diff(t_track_s)))
    k = max(1, int(round(CELL_FADE_S / dt / 2)))
    ker = np.hanning(2 * k + 1)
    ker /= ker.sum()
    sm = np.convolve(np.pad(vals, k, mode="edge"), ker, mode="valid")
    st = (np.interp(t_s, t_track_s, sm.real) + 1j * np.interp(t_s, t_track_s, sm.imag)).astype(np.complex64)
    amp = np.interp(t_s, t_track_s, np.abs(sm)).astype(np.float32)
    return st, amp


def windblown(n: int, prf_hz: float, wind_mps: float, rng: np.random.Generator) -> np.ndarray:
    """Unit-power complex Gaussian clutter fluctuation with a wind-dependent spectrum."""
    m = sfft.next_fast_len(n)
    f = sfft.fftfreq(m, 1.0 / prf_hz)
    width = 0.3 + 0.5 * wind_mps
    shape = np.exp(-np.abs(f) / width)
    x = (rng.standard_normal(m) + 1j * rng.standard_normal(m)) * shape
    y = sfft.ifft(x, workers=1)[:n]
    p = np.mean(np.abs(y) ** 2)
    return (y / np.sqrt(p)).astype(np.complex64) if p > 0 else y.astype(np.complex64)


def windblown_fraction_db(wind_mps: float) -> float:
    """Power of the wind-blown clutter relative to the stationary clutter [dB]."""
    return -32.0 + 1.5 * wind_mps


def artifacts(n: int, prf_hz: float, rate_per_min: float, rng: np.random.Generator) -> tuple[np.ndarray, list]:
    """Radar-2 spectral artifacts: impulsive bursts and short spurious tones.

    Returns the additive signal (complex64 [n]) and a list of (kind, t_s, params).
    """
    out = np.zeros(n, np.complex64)
    events = []
    dur = n / prf_hz
    k = rng.poisson(rate_per_min * dur / 60.0) if rate_per_min > 0 else 0
    for _ in range(k):
        t0 = rng.uniform(0, dur)
        i0 = int(t0 * prf_hz)
        if rng.uniform() < 0.5:
            w = int(rng.integers(1, 30))
            lvl = rng.uniform(25, 45)
            i1 = min(n, i0 + w)
            a = 10 ** (lvl / 20)
            out[i0:i1] += (a * np.exp(1j * rng.uniform(0, 2 * np.pi, i1 - i0))).astype(np.complex64)
            events.append(("burst", t0, {"pulses": w, "level_db": lvl}))
        else:
            d = rng.uniform(0.5, 3.0)
            f0 = rng.uniform(-400, 400)
            lvl = rng.uniform(-15, 0)
            i1 = min(n, i0 + int(d * prf_hz))
            tt = np.arange(i1 - i0) / prf_hz
            taper = np.sin(np.pi * np.arange(i1 - i0) / max(1, i1 - i0)) ** 2
            out[i0:i1] += (10 ** (lvl / 20) * taper * np.exp(2j * np.pi * f0 * tt)).astype(np.complex64)
            events.append(("tone", t0, {"duration_s": d, "doppler_hz": f0, "level_db": lvl}))
    return out, events


PARTS = frozenset({"static", "windblown", "phase", "thermal", "artifacts"})


def record(
    target: np.ndarray | None,
    n: int,
    *,
    t_track_s,
    cells,
    site: RadarSite,
    site_seed: int,
    wind_mps: float,
    rng: np.random.Generator,
    knob_phase_rms_rad: float = 0.0,
    clutter_scale_db: float = 0.0,
    parts=PARTS,
) -> tuple[np.ndarray, dict]:
    """What the radar records in the cell sequence: target + clutter, times the radar's
    phase noise (and the knob's), plus thermal noise and artifacts. complex64 [n].

    ``parts`` (a subset of :data:`PARTS`) keeps only some of the background, for
    diagnostics; every random draw is made whatever is kept, so each part is the same
    realisation as in the full recording."""
    unknown = set(parts) - PARTS
    if unknown:
        raise ValueError(f"parts: unknown {sorted(unknown)} (expected a subset of {sorted(PARTS)})")
    prf = site.radar.prf_hz
    t = np.arange(n) / prf
    st, amp = clutter_envelope(t_track_s, cells, t, site, site_seed)
    g = np.float32(10 ** (clutter_scale_db / 20))
    frac = np.float32(10 ** (windblown_fraction_db(wind_mps) / 20))
    x = st * g if "static" in parts else np.zeros(n, np.complex64)
    wb = windblown(n, prf, wind_mps, rng)
    if "windblown" in parts:
        x += wb * amp * (g * frac)
    if target is not None:
        x += target
    theta = band_limited_phase(n, prf, site.phase_noise_rms_rad, rng, corner_hz=site.phase_noise_corner_hz)
    if knob_phase_rms_rad > 0:
        theta = theta + band_limited_phase(n, prf, knob_phase_rms_rad, rng)
    if "phase" in parts:
        x *= np.exp(1j * theta).astype(np.complex64)
    nz = rng.standard_normal((n, 2), dtype=np.float32) * np.float32(np.sqrt(0.5))
    if "thermal" in parts:
        x += nz[:, 0] + 1j * nz[:, 1]
    art, events = artifacts(n, prf, site.artifact_rate_per_min, rng)
    if "artifacts" in parts:
        x += art
    info = {"mean_clutter_cnr_db": float(20 * np.log10(np.mean(amp) * g + 1e-12)), "artifacts": len(events)}
    return x.astype(np.complex64, copy=False), info
