"""Per-CPI measurements of a measured drone flight and of the paper's model of it.

Everything is measured on a Blackman-Harris STFT *without* high-pass (clutter stays
in, so the floor around it can be read), on the paper's CPI (``n_fft`` pulses, 50 %
overlap). Frequencies of the target are relative to its body Doppler.

The paper's model of the flight is simulated once (:func:`simulate_blades`): the
blade signal of eq. (1) driven by the flight's own motor log (sub-CPI sampling),
without envelope, on a zero-Doppler track, so its spectrum is body-relative. The
alpha envelope, S_blade and S_body are calibrated against the measurement
(:func:`calibrate`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.fft as sfft
from scipy.signal.windows import blackmanharris

from ..rotors import sampling as sampling
from ..io.motorlog import MotorLog
from ..synthesis.model import ModelExtensions, Scaling, SynthesisConfig, Track, synthesize

DB = 10.0 / np.log(10.0)


@dataclass
class Stft:
    """Power periodogram ``p`` float64 [n_t, n_fft] on centred Doppler ``f_hz``, CPI
    centres ``t_s`` [n_t]; ``window`` the analysis window."""

    p: np.ndarray
    t_s: np.ndarray
    f_hz: np.ndarray
    window: np.ndarray

    @property
    def bin_hz(self) -> float:
        return float(self.f_hz[1] - self.f_hz[0])

    def at(self, f: np.ndarray) -> np.ndarray:
        """Fractional bin index of Doppler ``f`` [Hz]."""
        return (np.asarray(f) - self.f_hz[0]) / self.bin_hz


def stft_power(iq: np.ndarray, prf_hz: float, n_fft: int, overlap: float = 0.5) -> Stft:
    """Blackman-Harris periodogram of every CPI wholly inside ``iq``."""
    hop = int(round(n_fft * (1 - overlap)))
    n_t = 1 + (len(iq) - n_fft) // hop
    if n_t < 1:
        raise ValueError(f"iq has {len(iq)} pulses, fewer than n_fft={n_fft}")
    w = blackmanharris(n_fft, sym=False)
    idx = np.arange(n_t)[:, None] * hop + np.arange(n_fft)[None, :]
    frames = np.asarray(iq, np.complex128)[idx] * w
    X = sfft.fftshift(sfft.fft(frames, axis=1, workers=1), axes=1)
    p = X.real ** 2 + X.imag ** 2
    t = (np.arange(n_t) * hop + n_fft / 2) / prf_hz
    f = sfft.fftshift(sfft.fftfreq(n_fft, 1.0 / prf_hz))
    return Stft(p, t, f, w)


def noise_power_factor(window: np.ndarray) -> float:
    """kappa = n sum(w^4) / (sum w^2)^2 of the analysis window ``w`` [n] (2.76 for
    Blackman-Harris): the factor by which the periodogram's noise in a band of bins
    varies more than independent bins would.

    The power of a line summed over the band of bins that holds it, minus the
    band's noise, P = sum_k |S_k + N_k|^2 - n_b fl (fl the mean noise per bin), has
    variance kappa (2 P fl + n_b fl^2): the cross term sum_k 2 Re(S_k N_k*) is
    2 Re(n sum_t w_t^2 s_t nu_t*) (Parseval, the band holding the line), of variance
    2 n^2 sigma^2 sum(w^4 |s|^2) = kappa 2 P fl for a line of constant amplitude; and
    the window makes neighbouring bins' noise correlated, sum_d |rho_d|^2 = kappa
    (Parseval again), so the noise term's variance is kappa n_b fl^2. Independent
    bins (kappa = 1) understate the std of the band power by sqrt(2.76) = 1.66 for
    Blackman-Harris (checked by simulation: 2.5-3.0 at 15-40 dB)."""
    w2 = np.asarray(window, float) ** 2
    return float(len(w2) * np.sum(w2 ** 2) / np.sum(w2) ** 2)


def cpi_average(t_s: np.ndarray, x: np.ndarray, cpi_t: np.ndarray, window: np.ndarray, prf_hz: float,
                n_points: int = 64) -> np.ndarray:
    """Average of the series ``x(t)`` over each CPI, weighted by the window's power
    profile (what a periodogram 'sees'): float [len(cpi_t)] (clamped at the ends)."""
    n = len(window)
    k = np.linspace(0, n - 1, n_points).astype(int)
    wk = window[k] ** 2
    wk = wk / wk.sum()
    tt = cpi_t[:, None] + (k[None, :] - n / 2) / prf_hz
    return (np.interp(tt, t_s, x) * wk).sum(axis=1)


def body_doppler(flight, t_s: np.ndarray) -> np.ndarray:
    """Body Doppler from the track [Hz] at times ``t_s`` (positive = approaching)."""
    v = np.interp(t_s, flight.track_time_s, flight.track_radial_velocity_mps)
    return -2.0 * v / flight.wavelength_m


def refine_peak(st: Stft, f0: np.ndarray, search_hz: float) -> np.ndarray:
    """Strongest bin within ``search_hz`` of ``f0`` per CPI, parabolic-refined [Hz]."""
    out = np.empty(len(f0))
    lp = np.log(st.p + 1e-300)
    for i, fc in enumerate(f0):
        lo = max(1, int(np.floor(st.at(fc - search_hz))))
        hi = min(len(st.f_hz) - 2, int(np.ceil(st.at(fc + search_hz))))
        if hi <= lo:
            out[i] = fc
            continue
        j = lo + int(np.argmax(st.p[i, lo:hi + 1]))
        a, b, c = lp[i, j - 1], lp[i, j], lp[i, j + 1]
        d = 0.5 * (a - c) / (a - 2 * b + c) if (a - 2 * b + c) < 0 else 0.0
        out[i] = st.f_hz[0] + (j + np.clip(d, -0.5, 0.5)) * st.bin_hz
    return out


def band_power(p_row: np.ndarray, st: Stft, f_c: float, half_hz: float) -> tuple[float, int]:
    """Sum of the periodogram within ``half_hz`` of ``f_c`` and the number of bins."""
    lo = int(np.ceil(st.at(f_c - half_hz)))
    hi = int(np.floor(st.at(f_c + half_hz)))
    lo, hi = max(lo, 0), min(hi, len(st.f_hz) - 1)
    if hi < lo:
        return 0.0, 0
    return float(p_row[lo:hi + 1].sum()), hi - lo + 1


def local_floor(p_row: np.ndarray, st: Stft, f_c: float, excl_hz: float, span_hz: float) -> float:
    """Mean noise level per bin near ``f_c`` (median / ln 2 of the bins within
    ``span_hz`` but farther than ``excl_hz``)."""
    lo = max(int(np.ceil(st.at(f_c - span_hz))), 0)
    hi = min(int(np.floor(st.at(f_c + span_hz))), len(st.f_hz) - 1)
    if hi <= lo:
        return np.nan
    seg = p_row[lo:hi + 1]
    f = st.f_hz[lo:hi + 1]
    seg = seg[np.abs(f - f_c) > excl_hz]
    if len(seg) < 4:
        return np.nan
    return float(np.median(seg) / np.log(2.0))


def simulate_blades(log: MotorLog, n_pulses: int, prf_hz: float, *, wavelength_m: float, n_blades: int,
                    blade_length_m: float, n_fft: int, seed: int, extensions: ModelExtensions | None = None,
                    alpha_s: float = 0.0, s_blade: float = 1.0, s_body: float = 0.0, track: Track | None = None,
                    window_pulses: int = 2500) -> tuple[np.ndarray, np.ndarray]:
    """The paper's model of a flight: returns (iq complex64 [n_pulses], rev_s
    float32 [n_pulses, n_motors]) with sub-CPI sampled speeds of ``log``.

    Without ``track`` the body is at zero Doppler (spectrum relative to the body).
    ``extensions``: model extensions acting inside the synthesis (default none)."""
    cfg = sampling.SamplingConfig(n_fft=n_fft, window_pulses=window_pulses)
    rev = sampling.sub_cpi(log, n_pulses, prf_hz, cfg)
    dur = n_pulses / prf_hz
    trk = track if track is not None else Track.constant_velocity(1000.0, 0.0, dur)
    ext = extensions if extensions is not None else ModelExtensions()
    if alpha_s > 0 and ext.envelope_gain is None:
        ext = replace(ext, envelope_gain=_unit_envelope)  # the alpha envelope as the FFT filter of eq. (2)
    config = SynthesisConfig.of(prf_hz=prf_hz, wavelength_m=wavelength_m, n_blades=n_blades,
                                blade_length_m=blade_length_m, scaling=Scaling(s_body, s_blade, alpha_s), extensions=ext)
    iq = synthesize(config, trk, rev, seed=seed)
    return iq, rev


def _unit_envelope(f_hz):
    return np.ones(len(f_hz), np.float32)
