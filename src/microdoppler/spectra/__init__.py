"""Spectrograms (the paper's STFT) and the one SNR measure used everywhere."""
