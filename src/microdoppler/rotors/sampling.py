"""Motor-speed sampling variants (paper §V.A.1, Fig. 8).

Each variant turns a sparse, jittery motor log into rotation rates at pulse rate,
``rev_s : ndarray, float32 [n_pulses, n_motors]``, that drive :mod:`synthesis`.

``per_cpi``
    One value per CPI (4096 pulses) from a piecewise cubic spline of the log, held
    constant over the CPI: speeds jump at CPI boundaries.
``sub_cpi``
    The log is decimated to 8 values per CPI (anti-aliased), upsampled to the PRF by
    zero insertion and a low-pass interpolating FIR (``scipy.signal.resample_poly``,
    factor ``n_fft / 8`` = 512; the paper's "128" is inconsistent with 4096/8), then
    smoothed by a centred rolling average of ``window_pulses`` (paper: 1000-3500).
``single_motor``
    ``sub_cpi`` with one rotor (motor 0).
``fixed_speeds``
    One constant speed for every motor over the whole flight, drawn uniformly within
    ±``spread`` of the drone model's typical speed (Table IV: 60 Hz Matrice, 80 Hz
    Inspire) with an explicit seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import decimate, resample_poly

from ..configfields import check_ranges, knob
from ..io.motorlog import MotorLog

VARIANTS = ("sub_cpi", "per_cpi", "single_motor", "fixed_speeds")


@dataclass(frozen=True)
class SamplingConfig:
    """Settings of the sampling variants.

    Parameters
    ----------
    n_fft : int
        CPI length in pulses.
    sub_cpi_per_cpi : int
        Decimated samples per CPI for ``sub_cpi`` (paper: 8).
    window_pulses : int
        Rolling-average length for ``sub_cpi`` [pulses] (paper: 1000-3500).
    fixed_spread : float
        Relative half-width of the ``fixed_speeds`` draw around the typical speed.

    ``sub_cpi_pad`` is a fixed setting (``config=False``, described by its field).
    """

    n_fft: int = 4096
    sub_cpi_per_cpi: int = 8
    window_pulses: int = 2500
    fixed_spread: float = 0.1
    sub_cpi_pad: int = knob(
        16,
        "Decimated samples of edge padding against filter transients (``sub_cpi``).",
        minimum=0,
        config=False,
    )

    def __post_init__(self):
        check_ranges(self, "rotors.sampling", all_fields=True)  # the config=False knob's range
        if self.n_fft % self.sub_cpi_per_cpi:
            raise ValueError(f"n_fft={self.n_fft} must be a multiple of sub_cpi_per_cpi={self.sub_cpi_per_cpi}")
        if not 1 <= self.window_pulses <= 4 * self.n_fft:
            raise ValueError(f"window_pulses={self.window_pulses} must be in [1, {4 * self.n_fft}]")
        if not 0 <= self.fixed_spread < 1:
            raise ValueError(f"fixed_spread={self.fixed_spread} must be in [0, 1)")


def log_curve(time_s: np.ndarray, values: np.ndarray):
    """The curve a motor log's rows stand for, as every variant reads it: the natural
    cubic spline through (``time_s``, ``values`` [n] or [n, k]), held at its end values
    beyond the rows. Returns ``f(t)``."""
    spl = CubicSpline(time_s, values, bc_type="natural", extrapolate=False, axis=0)
    lo, hi = time_s[0], time_s[-1]
    return lambda t: spl(np.clip(t, lo, hi))


def _spline(log: MotorLog, motor: int):
    return log_curve(log.time_s, log.rev_s[:, motor])


def per_cpi_knots(log: MotorLog, n_pulses: int, prf_hz: float, cfg: SamplingConfig = SamplingConfig()) -> np.ndarray:
    """The ``per_cpi`` speeds, one row per CPI: float64 [ceil(n_pulses / n_fft), n_motors] rev/s.

    :func:`per_cpi` holds row k over pulses k * n_fft to (k + 1) * n_fft - 1.
    """
    n_cpi = -(-n_pulses // cfg.n_fft)
    t_centre = (np.arange(n_cpi) * cfg.n_fft + cfg.n_fft / 2) / prf_hz
    return np.column_stack([_spline(log, m)(t_centre) for m in range(log.n_motors)])


def per_cpi(log: MotorLog, n_pulses: int, prf_hz: float, cfg: SamplingConfig = SamplingConfig()) -> np.ndarray:
    """One speed per CPI (value of the cubic spline at the CPI centre), held."""
    knots = per_cpi_knots(log, n_pulses, prf_hz, cfg)
    out = np.empty((n_pulses, log.n_motors), np.float32)
    for m in range(log.n_motors):
        out[:, m] = np.repeat(knots[:, m], cfg.n_fft)[:n_pulses]
    return out


def _moving_average(x: np.ndarray, w: int) -> np.ndarray:
    """Centred rolling average of length ``w`` with edge values held."""
    if w <= 1:
        return x
    h = w // 2
    xp = np.concatenate([np.full(h, x[0]), x, np.full(w - h, x[-1])])
    c = np.cumsum(xp, dtype=np.float64)
    c = np.concatenate([[0.0], c])
    return (c[w : w + len(x)] - c[: len(x)]) / w


def sub_cpi_knots(
    log: MotorLog, motor: int, n_pulses: int, prf_hz: float, cfg: SamplingConfig = SamplingConfig()
) -> np.ndarray:
    """The decimated log of ``sub_cpi`` (before upsampling): float64 [n_knots] rev/s.

    ``sub_cpi_per_cpi`` samples per CPI, i.e. one every ``up = n_fft / sub_cpi_per_cpi``
    pulses, with ``cfg.sub_cpi_pad`` samples of padding at each end:
    n_knots = ceil(n_pulses / up) + 2 * sub_cpi_pad. :func:`sub_cpi_from_knots` turns
    them into the per-pulse speeds.
    """
    up = cfg.n_fft // cfg.sub_cpi_per_cpi
    fs_dec = prf_hz / up
    oversample = 8
    pad = cfg.sub_cpi_pad
    n_dec = -(-n_pulses // up) + 2 * pad
    t_fine = (np.arange(n_dec * oversample) - pad * oversample) / (fs_dec * oversample)
    fine = _spline(log, motor)(t_fine)
    return decimate(fine, oversample, ftype="fir", zero_phase=True)


def sub_cpi_from_knots(knots: np.ndarray, n_pulses: int, *, up: int, pad: int, window_pulses: int) -> np.ndarray:
    """Per-pulse ``sub_cpi`` speeds from :func:`sub_cpi_knots`: float64 [n_pulses] rev/s.

    Upsampled by ``up`` (zero insertion and a low-pass interpolating FIR,
    ``scipy.signal.resample_poly``), cut to the flight (``pad`` knots dropped at the
    start) and smoothed by a centred rolling average of ``window_pulses``.
    """
    upsampled = resample_poly(np.asarray(knots, np.float64), up, 1)
    x = upsampled[pad * up : pad * up + n_pulses]
    return _moving_average(x, window_pulses)


def sub_cpi_motor(
    log: MotorLog, motor: int, n_pulses: int, prf_hz: float, cfg: SamplingConfig = SamplingConfig()
) -> np.ndarray:
    """Sub-CPI sampling of one motor: [n_pulses] float64 rev/s."""
    return sub_cpi_from_knots(
        sub_cpi_knots(log, motor, n_pulses, prf_hz, cfg),
        n_pulses,
        up=cfg.n_fft // cfg.sub_cpi_per_cpi,
        pad=cfg.sub_cpi_pad,
        window_pulses=cfg.window_pulses,
    )


def sub_cpi(
    log: MotorLog, n_pulses: int, prf_hz: float, cfg: SamplingConfig = SamplingConfig(), motors: list[int] | None = None
) -> np.ndarray:
    motors = list(range(log.n_motors)) if motors is None else motors
    out = np.empty((n_pulses, len(motors)), np.float32)
    for j, m in enumerate(motors):
        out[:, j] = sub_cpi_motor(log, m, n_pulses, prf_hz, cfg)
    return out


def fixed_speeds(
    n_motors: int, n_pulses: int, typical_hz: float, seed: int, cfg: SamplingConfig = SamplingConfig()
) -> tuple[np.ndarray, float]:
    """Constant speeds: returns (rev_s [n_pulses, n_motors], the drawn speed [rev/s])."""
    rng = np.random.default_rng(seed)
    f = float(typical_hz * rng.uniform(1 - cfg.fixed_spread, 1 + cfg.fixed_spread))
    return np.full((n_pulses, n_motors), f, np.float32), f


def resample(
    variant: str,
    log: MotorLog,
    n_pulses: int,
    prf_hz: float,
    *,
    typical_hz: float | None = None,
    seed: int = 0,
    cfg: SamplingConfig = SamplingConfig(),
) -> np.ndarray:
    """Rotation rates at pulse rate for one sampling ``variant`` (paper §V.A.1).

    Parameters
    ----------
    variant : {"per_cpi", "sub_cpi", "single_motor", "fixed_speeds"}
        ``per_cpi``: each motor's logged speed averaged per CPI; ``sub_cpi``: a
        rolling average sampled several times per CPI; ``single_motor``: motor 0's
        ``sub_cpi`` speed on every rotor; ``fixed_speeds``: one constant speed drawn
        around ``typical_hz``.
    log : MotorLog
        The logged speeds, on the radar clock.
    n_pulses : int
        Pulses of the flight.
    prf_hz : float
        Pulse repetition frequency [Hz].
    typical_hz : float, optional
        The drone model's typical rotor speed [rev/s] (``fixed_speeds`` only).
    seed : int
        Seed of the ``fixed_speeds`` draw.
    cfg : SamplingConfig
        CPI length, sub-CPI samples, rolling-average length.

    Returns
    -------
    ndarray, float32 [n_pulses, n_motors]
        Rotor speeds [rev/s] at every pulse (``synthesize``'s ``rev_s``).

    Raises
    ------
    ValueError
        For an unknown ``variant``, or ``fixed_speeds`` without ``typical_hz``.

    See Also
    --------
    microdoppler.synthesis.synthesize, microdoppler.datasets.fit_twin

    Examples
    --------
    >>> import numpy as np
    >>> from microdoppler.io import MotorLog
    >>> from microdoppler.rotors import resample
    >>> t = np.arange(0.0, 2.0, 0.05)
    >>> log = MotorLog(t, np.column_stack([4800 + 600 * t] * 4).astype(np.float32))
    >>> rev_s = resample("per_cpi", log, 7300, 7300.0)
    >>> rev_s.shape, rev_s.dtype
    ((7300, 4), dtype('float32'))
    >>> bool(80.0 <= rev_s.min() <= rev_s.max() <= 90.0)
    True
    """
    if variant == "per_cpi":
        return per_cpi(log, n_pulses, prf_hz, cfg)
    if variant == "sub_cpi":
        return sub_cpi(log, n_pulses, prf_hz, cfg)
    if variant == "single_motor":
        return sub_cpi(log, n_pulses, prf_hz, cfg, motors=[0])
    if variant == "fixed_speeds":
        if typical_hz is None:
            raise ValueError("fixed_speeds needs typical_hz (the drone model's typical rotor speed)")
        return fixed_speeds(log.n_motors, n_pulses, typical_hz, seed, cfg)[0]
    raise ValueError(f"variant={variant!r} must be one of {VARIANTS}")
