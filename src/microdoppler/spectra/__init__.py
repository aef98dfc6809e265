"""Spectrograms (the paper's STFT) and the one SNR measure used everywhere."""

from .snr import flight_snr_db, line_snr_db
from .spectrogram import Spectrogram, SpectrogramConfig, spectrogram

__all__ = ["Spectrogram", "SpectrogramConfig", "spectrogram", "line_snr_db", "flight_snr_db"]
