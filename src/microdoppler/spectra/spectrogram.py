"""Spectrograms as in the paper (§II, §III.C): 15 Hz high-pass, 4096-point
Blackman-Harris STFT with 50 % overlap, the central 480 Doppler bins, in dB; and
20-timestep image tiles."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import ShortTimeFFT, butter, sosfiltfilt
from scipy.signal.windows import blackmanharris


@dataclass(frozen=True)
class SpectrogramConfig:
    """STFT settings.

    Parameters
    ----------
    n_fft : int
        Window length = FFT length [pulses] (one CPI).
    overlap : float
        Fraction of overlap between successive CPIs.
    highpass_hz : float
        High-pass cut-off removing stationary clutter (0 disables).
    n_bins : int
        Central Doppler bins kept (0 keeps all).
    tile_timesteps : int
        Timesteps per image tile.
    """

    n_fft: int = 4096
    overlap: float = 0.5
    highpass_hz: float = 15.0
    highpass_order: int = 4
    n_bins: int = 480
    tile_timesteps: int = 20

    def __post_init__(self):
        if self.n_fft < 16:
            raise ValueError(f"n_fft={self.n_fft} must be >= 16")
        if not 0 <= self.overlap < 1:
            raise ValueError(f"overlap={self.overlap} must be in [0, 1)")
        if self.highpass_hz < 0:
            raise ValueError(f"highpass_hz={self.highpass_hz} must be >= 0")
        if not 0 <= self.n_bins <= self.n_fft:
            raise ValueError(f"n_bins={self.n_bins} must be in [0, n_fft={self.n_fft}]")
        if self.tile_timesteps < 1:
            raise ValueError(f"tile_timesteps={self.tile_timesteps} must be >= 1")

    @property
    def hop(self) -> int:
        return int(round(self.n_fft * (1 - self.overlap)))

    def tile_duration_s(self, prf_hz: float) -> float:
        """Time spanned by one tile: (T - 1) hops + one window (§V.C: ~5.8 s)."""
        return ((self.tile_timesteps - 1) * self.hop + self.n_fft) / prf_hz


@dataclass
class Spectrogram:
    """Power spectrogram.

    Attributes
    ----------
    power_db : ndarray, float32 [n_timesteps, n_bins]
        10 log10 |STFT|^2 (uncalibrated, relative).
    time_s : ndarray [n_timesteps]
        Centre time of each CPI [s].
    doppler_hz : ndarray [n_bins]
        Doppler of each bin [Hz]; positive = approaching.
    """

    power_db: np.ndarray
    time_s: np.ndarray
    doppler_hz: np.ndarray

    @property
    def bin_hz(self) -> float:
        return float(self.doppler_hz[1] - self.doppler_hz[0])


def highpass(iq: np.ndarray, prf_hz: float, cutoff_hz: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth high-pass of complex slow-time samples."""
    if cutoff_hz <= 0:
        return iq
    sos = butter(order, cutoff_hz, btype="highpass", fs=prf_hz, output="sos")
    return sosfiltfilt(sos, iq).astype(np.complex64)


def spectrogram(iq: np.ndarray, prf_hz: float, cfg: SpectrogramConfig = SpectrogramConfig()) -> Spectrogram:
    """Paper spectrogram of slow-time ``iq`` (complex64 [n_pulses]).

    Windows lie wholly inside the record (no zero padding at the ends), so the
    number of timesteps is ``1 + (n_pulses - n_fft) // hop``.
    """
    iq = np.asarray(iq)
    if iq.ndim != 1 or len(iq) < cfg.n_fft:
        raise ValueError(f"iq must be 1-D with >= n_fft={cfg.n_fft} pulses, got shape {iq.shape}")
    x = highpass(iq, prf_hz, cfg.highpass_hz, cfg.highpass_order)
    win = blackmanharris(cfg.n_fft, sym=False)
    stft = ShortTimeFFT(win, hop=cfg.hop, fs=prf_hz, fft_mode="centered", scale_to=None)
    k0 = stft.lower_border_end[1]
    k1 = stft.upper_border_begin(len(x))[1]
    S = stft.stft(x, p0=k0, p1=k1)  # [n_freq, n_time]
    f = stft.f
    if cfg.n_bins:
        c = cfg.n_fft // 2
        lo = c - cfg.n_bins // 2
        S = S[lo:lo + cfg.n_bins]
        f = f[lo:lo + cfg.n_bins]
    p = (S.real ** 2 + S.imag ** 2).T
    t = stft.t(len(x), p0=k0, p1=k1)
    return Spectrogram(10 * np.log10(p + 1e-30).astype(np.float32), t, f)


def tiles(spec: Spectrogram, timesteps: int = 20) -> np.ndarray:
    """Non-overlapping images of ``timesteps`` CPIs: float32 [n_tiles, timesteps, n_bins]."""
    n = spec.power_db.shape[0] // timesteps
    return spec.power_db[: n * timesteps].reshape(n, timesteps, -1)
