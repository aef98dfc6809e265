"""Random processes shared by the emulator's reality knobs and the model extensions."""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter


def ou_process(n: int, dt_s: float, std: float, tau_s: float, rng: np.random.Generator) -> np.ndarray:
    """Stationary Ornstein-Uhlenbeck process: float64 [n] at spacing ``dt_s`` [s],
    standard deviation ``std``, correlation time ``tau_s`` [s] (exact AR(1)
    discretisation; the first sample is drawn from the stationary law)."""
    if n <= 0:
        return np.zeros(0)
    a = np.exp(-dt_s / tau_s)
    w = rng.standard_normal(n) * std * np.sqrt(1 - a * a)
    w[0] = rng.standard_normal() * std
    return lfilter([1.0], [1.0, -a], w)
