"""Reality knobs: the catalog's causes as physics of the emulated world.

Every cause of :data:`microdoppler.synthesis.catalog.CAUSES` (except ``none``) can be switched
on per flight with the catalog's parameter names, units and signs:

``sideband_asymmetry``  {asymmetry_db}
    The blade signal (relative to the body) is filtered with gain 10^(+a/40) above the
    body Doppler and 10^(-a/40) below it, so upper/lower sideband power = 10^(a/10).
``sideband_fading``     {fading_std_db, timescale_s}
    The blade signal is multiplied by 10^(x(t)/20), x an Ornstein-Uhlenbeck process in
    dB with standard deviation ``fading_std_db`` and correlation time ``timescale_s``.
``body_fluctuation``    {body_std_db, timescale_s}
    The body amplitude is multiplied by 10^(y(t)/20), y OU in dB with standard
    deviation ``body_std_db`` and correlation time ``timescale_s`` (default
    :data:`BODY_FLUCTUATION_TAU_S`).
``motor_log_lag``       {lag_s}
    A log row stamped t reports the true speed at t - lag_s.
``motor_speed_scale``   {scale}
    logged speed = true speed / scale.
``phase_noise``         {rms_rad, skirt_dbc_hz}
    The whole flight echo (target, clutter, noise) is multiplied by exp(j theta(t)),
    theta Gaussian with a flat spectrum on |f| < 100 Hz and rms ``rms_rad``. Either
    parameter may be given; the other follows analytically from this process
    (:func:`microdoppler.synthesis.catalog.flat_skirt_dbc_hz`: skirt_dbc_hz is the
    single-sideband density at 50 Hz relative to the carrier), and the key records
    both (given both, they must agree within 0.1 dB). It is an
    episode of the flight recording: the target-free ``background/iq`` (recorded at
    another time) does not carry it.
``blade_imbalance``     {imbalance_db}
    One blade of every rotor scatters 10^(-imbalance_db/20) of the others
    (:func:`imbalance_amplitudes`: amplitudes scaled to sum to the blade count, so the
    blade-passing lines keep the flight's drawn level), passed to the synthesis of each
    nested wire of the tapered blade: lines appear at the multiples of the rotation
    rate that are not multiples of the blade count (two blades: the odd ones, at
    ((1 - a) / (1 + a))^2 of the blade's own line power relative to the even ones).
    The worlds carry it as a property of an airframe (:mod:`.profiles`).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from ..synthesis.catalog import CAUSES, PHASE_NOISE_BANDWIDTH_HZ, flat_rms_rad, flat_skirt_dbc_hz
from ..synthesis.processes import ou_process  # noqa: F401 (used here and re-exported)

#: correlation time of the body_fluctuation knob [s] (catalog: ~0.3 s)
BODY_FLUCTUATION_TAU_S = 0.3
#: defaults of secondary parameters
DEFAULTS = {"sideband_fading": {"timescale_s": 1.5}, "body_fluctuation": {"timescale_s": BODY_FLUCTUATION_TAU_S}}
#: sampling interval of the slow gain processes before interpolation to pulse rate [s]
GAIN_DT_S = 0.01


def validate_effects(effects: Mapping | None) -> dict:
    """Check an ``{cause: {param: value}}`` mapping against the catalog.

    Returns a new dict with secondary parameters filled in. ``none`` may be given with
    no parameters and is dropped.
    """
    out: dict = {}
    for cause, params in dict(effects or {}).items():
        if cause not in CAUSES:
            raise ValueError(f"effect {cause!r} is not a catalog cause; expected one of {list(CAUSES)}")
        if cause == "none":
            if params:
                raise ValueError("effect 'none' takes no parameters")
            continue
        params = dict(params or {})
        names = [p.name for p in CAUSES[cause].params]
        for k in params:
            if k not in names:
                raise ValueError(f"effect {cause!r}: parameter {k!r} unknown; expected {names}")
        full = {**DEFAULTS.get(cause, {}), **params}
        if cause == "phase_noise":
            full = _phase_noise_params(full)
        for k in names:
            if k not in full:
                raise ValueError(f"effect {cause!r}: parameter {k!r} missing")
            v = float(full[k])
            if not np.isfinite(v):
                raise ValueError(f"effect {cause!r}: {k}={v} must be finite")
            full[k] = v
        if cause == "sideband_fading" and not (full["fading_std_db"] >= 0 and full["timescale_s"] > 0):
            raise ValueError(f"sideband_fading: fading_std_db={full['fading_std_db']} must be >= 0 and "
                             f"timescale_s={full['timescale_s']} > 0")
        if cause == "body_fluctuation" and not (full["body_std_db"] >= 0 and full["timescale_s"] > 0):
            raise ValueError(f"body_fluctuation: body_std_db={full['body_std_db']} must be >= 0 and "
                             f"timescale_s={full['timescale_s']} > 0")
        if cause == "motor_speed_scale" and not full["scale"] > 0:
            raise ValueError(f"motor_speed_scale: scale={full['scale']} must be > 0")
        if cause == "phase_noise" and not full["rms_rad"] >= 0:
            raise ValueError(f"phase_noise: rms_rad={full['rms_rad']} must be >= 0")
        if cause == "blade_imbalance" and not 0 <= full["imbalance_db"] <= 60:
            raise ValueError(f"blade_imbalance: imbalance_db={full['imbalance_db']} must be in [0, 60] dB")
        if cause == "motor_log_lag" and not abs(full["lag_s"]) < 10:
            raise ValueError(f"motor_log_lag: lag_s={full['lag_s']} must be within +-10 s")
        out[cause] = {k: full[k] for k in names}  # the catalog's order
    return out


def _phase_noise_params(p: dict) -> dict:
    """rms_rad and skirt_dbc_hz of the knob's flat process, either one given."""
    p = dict(p)
    try:
        vals = {k: float(v) for k, v in p.items()}
    except (TypeError, ValueError):
        raise ValueError(f"effect 'phase_noise': parameters {p} must be numbers") from None
    if "rms_rad" in vals and vals["rms_rad"] < 0:
        raise ValueError(f"phase_noise: rms_rad={vals['rms_rad']} must be >= 0")
    if "rms_rad" in vals and "skirt_dbc_hz" in vals:
        want = flat_skirt_dbc_hz(vals["rms_rad"]) if vals["rms_rad"] > 0 else -300.0
        if not abs(want - vals["skirt_dbc_hz"]) <= 0.1:
            raise ValueError(f"phase_noise: skirt_dbc_hz={vals['skirt_dbc_hz']} disagrees with rms_rad="
                             f"{vals['rms_rad']} (whose flat skirt is {want:.2f} dBc/Hz); give one of them")
    elif "rms_rad" in vals:
        p["skirt_dbc_hz"] = flat_skirt_dbc_hz(vals["rms_rad"]) if vals["rms_rad"] > 0 else -300.0
    elif "skirt_dbc_hz" in vals:
        p["rms_rad"] = flat_rms_rad(vals["skirt_dbc_hz"])
    return p


class SlowGain:
    """A dB gain process sampled every :data:`GAIN_DT_S` and interpolated to any time.

    ``amplitude(t_s)`` returns 10^(x(t)/20) as float32.
    """

    def __init__(self, duration_s: float, std_db: float, tau_s: float, rng: np.random.Generator,
                 t0_s: float = 0.0):
        n = int(np.ceil(duration_s / GAIN_DT_S)) + 3
        self.t0_s = t0_s
        self.x_db = ou_process(n, GAIN_DT_S, std_db, tau_s, rng)

    def db(self, t_s: np.ndarray) -> np.ndarray:
        grid = self.t0_s + GAIN_DT_S * np.arange(len(self.x_db))
        return np.interp(t_s, grid, self.x_db)

    def amplitude(self, t_s: np.ndarray) -> np.ndarray:
        return (10.0 ** (self.db(t_s) / 20.0)).astype(np.float32)


def band_limited_phase(n: int, prf_hz: float, rms_rad: float, rng: np.random.Generator, *,
                       bandwidth_hz: float = PHASE_NOISE_BANDWIDTH_HZ, corner_hz: float | None = None) -> np.ndarray:
    """Gaussian phase error theta [n] (float64, rad) with rms ``rms_rad``.

    Flat spectrum on |f| < ``bandwidth_hz`` (the catalog's phase-noise knob), or, with
    ``corner_hz``, a Lorentzian spectrum 1 / (1 + (f/corner)^2) (an oscillator's own
    noise). Generated in the frequency domain over the whole record (circular).
    """
    if rms_rad == 0 or n == 0:
        return np.zeros(n)
    import scipy.fft as sfft

    m = sfft.next_fast_len(n)
    f = sfft.rfftfreq(m, 1.0 / prf_hz)
    if corner_hz is None:
        shape = (f < bandwidth_hz).astype(np.float64)
    else:
        shape = 1.0 / np.sqrt(1.0 + (f / corner_hz) ** 2)
    shape[0] = 0.0
    spec = (rng.standard_normal(len(f)) + 1j * rng.standard_normal(len(f))) * shape
    th = sfft.irfft(spec, m, workers=1)[:n]
    s = th.std()
    return th * (rms_rad / s) if s > 0 else th


def imbalance_amplitudes(imbalance_db: float, n_blades: int, weak_blade: int = 0) -> tuple:
    """Per-blade scattering amplitudes of a rotor with one weak blade: blade
    ``weak_blade`` at 10^(-imbalance_db/20) of the others, all scaled to sum to
    ``n_blades`` (float tuple [n_blades]). For two blades a weak blade is the same as a
    strong one (only the amplitude ratio shows)."""
    if n_blades < 1 or not 0 <= weak_blade < n_blades:
        raise ValueError(f"weak_blade={weak_blade} must index one of n_blades={n_blades} blades")
    amps = np.ones(int(n_blades))
    amps[weak_blade] = 10.0 ** (-float(imbalance_db) / 20.0)
    return tuple(float(a) for a in amps * n_blades / amps.sum())


def asymmetry_envelope(asymmetry_db: float):
    """Envelope ``g(f)`` relative to the body Doppler: upper/lower power ratio 10^(a/10)."""
    up = 10.0 ** (asymmetry_db / 40.0)
    lo = 10.0 ** (-asymmetry_db / 40.0)

    def env(f_hz: np.ndarray) -> np.ndarray:
        g = np.where(f_hz > 0, up, lo)
        g = np.where(f_hz == 0, 1.0, g)
        return g.astype(np.float32)

    return env
