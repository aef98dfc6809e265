"""Spectrograms (the paper's STFT) and the one SNR measure used everywhere, on one
windowed periodogram kernel (:mod:`microdoppler.spectra.periodogram`)."""

from .periodogram import periodogram, stft, window
from .snr import flight_snr_db, line_snr_db
from .spectrogram import Spectrogram, SpectrogramConfig, spectrogram

__all__ = [
    "Spectrogram",
    "SpectrogramConfig",
    "spectrogram",
    "periodogram",
    "stft",
    "window",
    "line_snr_db",
    "flight_snr_db",
]
