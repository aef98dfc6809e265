"""An independent generator of measured drone flights with known discrepancies.

It tests the diagnosis on effects that the project's emulator did not make: it
imports only numpy, scipy and :mod:`microdoppler.io.flightzarr` (the container), and
shares no code with ``microdoppler.emulator``, ``microdoppler.causes.extensions`` or
``microdoppler.synthesis.processes``. Its constants and process shapes differ on purpose:

- radars: ``gen_l`` (1.25 GHz, PRF 6500 Hz), ``gen_s`` (2.9 GHz, PRF 9000 Hz) and
  ``gen_2k`` (1.25 GHz, PRF 2000 Hz: 4096 pulses last 2 s);
- blades: its own thin-wire sum of eq. (1) of the paper, per motor and blade,
  L exp(-j 4 pi/lambda L/2 cos phi) sinc(4 pi/lambda L/2 cos phi) with the blade
  phase the time integral of the rotation rate, then a frequency envelope
  exp(-alpha |f|) applied by one FFT over the record (relative to the body);
- ``sideband_asymmetry``: the envelope times 10^(+a/40) above and 10^(-a/40) below;
- ``sideband_fading``: a two-state telegraph gain in dB (levels +-std, switching
  at rate 1 / (2 T) each way, so its correlation is exp(-|tau| / T));
- ``body_fluctuation``: a Gaussian dB process with the spectrum of a critically
  damped second-order filter, correlation (1 + |tau|/theta) exp(-|tau|/theta),
  scaled so that its 1/e time is ``timescale_s`` (theta = T / 2.1462);
- ``phase_noise``: a Gaussian phase with a Gaussian-shaped spectrum
  (``shape="gauss"``, exp(-f^2 / (2 fc^2)), fc = 60 Hz) or a 1/f-like one
  (``shape="flicker"``, 1 / (f + 5 Hz) up to 400 Hz), scaled to the requested
  single-sideband density at 50 Hz (first order: L(50 Hz) = two-sided S_theta(50 Hz));
  the background recording does not carry it;
- ``motor_log_lag`` / ``motor_speed_scale``: its own motor log at 25 Hz with
  timestamp jitter, rounded to 1 rpm; a row stamped t holds true(t - lag) / scale;
- ``blade_imbalance``: blade 0 of every rotor (or of the rotors listed in ``motors``)
  scatters with amplitude 10^(-imbalance_db/20) of the others (a tagged or chipped
  blade), so lines appear at odd multiples of the rotation rate.

Out-of-catalog effects (``GenCase.oddities``; no catalog cause describes them, so a
diagnosis must not call such a flight ``none``):

- ``second_scatterer``: a point on the airframe with its own Doppler, ``offset_hz``
  from the body, ``level_db`` relative to the body line, wandering by ``wander_hz``
  (a swinging payload);
- ``true_n_blades``: the propellers carry this many blades while the store declares
  ``N_BLADES`` (a wrong declared blade count);
- ``range_straddle``: the whole target's power drifts slowly as it crosses range
  cells: a raised cosine of ``depth_db`` over ``period_s``.

Birds (:func:`make_bird`): a flapping bird of its own kind, not the emulator's: a
body echo whose level follows the wing beat (a raised cosine of ``WING_DEPTH_DB``)
and a wing-tip scatterer whose radial displacement is a clipped sine at the wing-beat
rate (4-10 Hz, 6-14 cm), 6-12 dB below the body; a straight leg at 5-14 m/s.

Everything random comes from the case's seed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from microdoppler.io.flightzarr import Flight

C_MPS = 299792458.0
RADARS = {"gen_l": (1.25e9, 6500.0), "gen_s": (2.9e9, 9000.0), "gen_2k": (1.25e9, 2000.0)}
N_MOTORS, N_BLADES, BLADE_M = 4, 2, 0.21
HOVER_REV_S = 72.0
LOG_HZ = 25.0
#: depth of the wing beat's modulation of the bird body's echo [dB]
WING_DEPTH_DB = 4.0
#: critically damped correlation (1 + x) exp(-x) falls to 1/e at x = 2.1462
CRIT_1E = 2.1462


@dataclass(frozen=True)
class GenCase:
    """One flight to generate.

    effects : {cause: {param: value}} with the catalog's names; phase_noise takes
    ``skirt_dbc_hz`` and ``shape`` ("gauss" or "flicker").
    """

    flight_id: str
    seed: int
    radar: str = "gen_l"
    effects: dict = field(default_factory=dict)
    duration_s: float = 40.0
    snr_db: float = 40.0  # body line over the noise per bin of a 4096-pulse CPI (Hann gain)
    first_sideband_db: float = 8.0
    speed_mps: float | None = None  # radial speed; default drawn (7-11 m/s at gen_l, scaled for gen_s)
    oddities: dict = field(default_factory=dict)  # out-of-catalog effects (module docstring)


def _telegraph(n: int, dt: float, std: float, tau: float, rng) -> np.ndarray:
    """Two-state process +-std switching at rate 1/(2 tau) each way."""
    p = dt / (2 * tau)
    flips = rng.uniform(size=n) < p
    state = np.where(np.cumsum(flips) % 2 == 0, 1.0, -1.0) * (1.0 if rng.uniform() < 0.5 else -1.0)
    return std * state


def _crit_damped(n: int, dt: float, std: float, tau_1e: float, rng) -> np.ndarray:
    """Gaussian process, two cascaded first-order low-passes (theta = tau_1e / 2.1462)."""
    theta = tau_1e / CRIT_1E
    a = np.exp(-dt / theta)
    burn = int(10 * theta / dt) + 10
    w = rng.standard_normal(n + burn)
    x = lfilter([1 - a], [1, -a], lfilter([1 - a], [1, -a], w))[burn:]
    return std * x / x.std()


def _phase_noise(n: int, prf: float, skirt_dbc_hz: float, shape: str, rng) -> np.ndarray:
    m = n
    f = np.fft.rfftfreq(m, 1.0 / prf)
    if shape == "gauss":
        s = np.exp(-(f**2) / (2 * 60.0**2))
    elif shape == "flicker":
        s = np.where(f < 400.0, 1.0 / (f + 5.0), 0.0)
    else:
        raise ValueError(shape)
    s[0] = 0.0
    # two-sided PSD S(f) [rad^2/Hz]: scale so that S(50 Hz) = 10^(skirt/10)
    s50 = np.interp(50.0, f, s)
    S = s * 10 ** (skirt_dbc_hz / 10) / s50
    # a real Gaussian series with two-sided PSD S: rfft coefficients of variance S * prf * m / 2 per part
    spec = (rng.standard_normal(len(f)) + 1j * rng.standard_normal(len(f))) * np.sqrt(S * prf * m / 2)
    return np.fft.irfft(spec, m)


def _blade_sum(phi_rev: np.ndarray, lam: float, amps=None, n_blades: int = N_BLADES) -> np.ndarray:
    """Eq. (1) for one motor: sum over the blades of the thin-wire return, blade b with
    amplitude ``amps[b]`` (default all 1); ``phi_rev`` the rotor angle [rev] per pulse."""
    k = 4 * np.pi / lam
    out = np.zeros(len(phi_rev), np.complex128)
    for b in range(n_blades):
        c = np.cos(2 * np.pi * (phi_rev + b / n_blades))
        u = k * BLADE_M / 2 * c
        out += (1.0 if amps is None else amps[b]) * BLADE_M * np.exp(-1j * u) * np.sinc(u / np.pi)
    return out


def make_flight(case: GenCase) -> tuple[Flight, dict]:
    """The case's flight (flight-zarr container, with motor log and background) and
    its truth: ``{"effects": {cause: canonical params}, "realized_std_db": {param: the
    std of this flight's own fading / body gain path}, ...}``."""
    rng = np.random.default_rng(case.seed)
    carrier, prf = RADARS[case.radar]
    lam = C_MPS / carrier
    n = int(round(case.duration_s * prf))
    t = np.arange(n) / prf
    eff = case.effects
    # trajectory: a straight leg along the line of sight, with gentle speed changes
    sign = rng.choice([-1.0, 1.0])
    v0 = sign * rng.uniform(7.0, 11.0) * (1.25e9 / carrier) ** 0.5
    if case.speed_mps is not None:
        v0 = sign * case.speed_mps
    vr = v0 * (1 + 0.08 * np.sin(2 * np.pi * t / rng.uniform(15, 30) + rng.uniform(0, 6.3)))
    r = rng.uniform(900, 2000) + np.cumsum(vr) / prf
    # a long inbound leg turns back at 300 m (reflected path; the Doppler flips sign)
    turned = r < 300.0
    r = np.where(turned, 600.0 - r, r)
    vr = np.where(turned, -vr, vr)
    # rotor speeds: common slow variation and per-motor offsets (relative 3 %)
    tc = np.arange(-3.0, case.duration_s + 3.0, 0.01)
    common = (
        HOVER_REV_S
        * rng.uniform(0.9, 1.1)
        * (1 + 0.05 * np.sin(2 * np.pi * tc / rng.uniform(6, 12)) + 0.03 * np.sin(2 * np.pi * tc / rng.uniform(2.5, 4)))
    )
    offs = 1 + rng.normal(0, 0.03, N_MOTORS)
    wob = np.array([0.01 * np.sin(2 * np.pi * tc / rng.uniform(1.5, 3) + rng.uniform(0, 6.3)) for _ in range(N_MOTORS)])
    rev_c = common[None, :] * (offs[:, None] + wob)  # [motors, n_c]
    rev = np.array([np.interp(t, tc, rm) for rm in rev_c])  # [motors, n]
    phi = np.cumsum(rev, axis=1) / prf + rng.uniform(0, 1, (N_MOTORS, 1))
    odd = case.oddities
    nb_true = int(odd.get("true_n_blades", N_BLADES))
    imb = eff.get("blade_imbalance", {})
    weak = 10 ** (-imb.get("imbalance_db", 0.0) / 20)
    imb_motors = set(imb.get("motors", range(N_MOTORS)))
    amps = [[weak if (b == 0 and m in imb_motors) else 1.0 for b in range(nb_true)] for m in range(N_MOTORS)]
    blades = sum(_blade_sum(phi[m], lam, amps[m], nb_true) for m in range(N_MOTORS))
    blades = blades - blades.mean()
    # envelope relative to the body: exp(-alpha |f|), asymmetry, one FFT over the record
    fgrid = np.fft.fftfreq(n, 1.0 / prf)
    h = N_BLADES * HOVER_REV_S
    alpha = 5.5 / (20 * np.log10(np.e) * h)  # ~5.5 dB per harmonic beyond the wire's own roll-off
    H = np.exp(-alpha * np.abs(fgrid))
    a_db = eff.get("sideband_asymmetry", {}).get("asymmetry_db", 0.0)
    H = H * np.where(fgrid > 0, 10 ** (a_db / 40), np.where(fgrid < 0, 10 ** (-a_db / 40), 0.0))
    blades = np.fft.ifft(np.fft.fft(blades) * H)
    # levels: body line SNR per CPI bin; first sideband pair first_sideband_db below the body
    w = np.hanning(4096)
    g_bin = (w.sum() ** 2) / (w**2).sum()
    a_body = np.sqrt(10 ** (case.snr_db / 10) / g_bin)
    bl_spec = np.abs(np.fft.fft(blades)) ** 2
    band = np.abs(np.abs(fgrid) - h * np.median(offs) * common.mean() / HOVER_REV_S) < 0.25 * h
    p1 = bl_spec[band].sum() / n / 2  # mean power of one first sideband
    blades *= a_body * 10 ** (-case.first_sideband_db / 20) / np.sqrt(max(p1 / n, 1e-30))
    # slow gains
    dtg = 0.005
    tg = np.arange(0.0, case.duration_s + dtg, dtg)
    if "sideband_fading" in eff:
        p = eff["sideband_fading"]
        x = _telegraph(len(tg), dtg, p["fading_std_db"], p["timescale_s"], rng)
        blades *= 10 ** (np.interp(t, tg, x) / 20)
    realized = {}
    if "sideband_fading" in eff:
        realized["fading_std_db"] = float(x.std())
    body_amp = np.full(n, a_body)
    if "body_fluctuation" in eff:
        p = eff["body_fluctuation"]
        y = _crit_damped(len(tg), dtg, p["body_std_db"], p["timescale_s"], rng)
        body_amp = body_amp * 10 ** (np.interp(t, tg, y) / 20)
        realized["body_std_db"] = float(y.std())
    carrier_ph = np.exp(-1j * 4 * np.pi * r / lam)
    target = (body_amp + blades) * carrier_ph
    if "second_scatterer" in odd:
        p = odd["second_scatterer"]
        wander = p.get("wander_hz", 0.0) * np.sin(2 * np.pi * t / rng.uniform(4.0, 8.0) + rng.uniform(0, 6.3))
        ph2 = 2 * np.pi * np.cumsum(p["offset_hz"] + wander) / prf
        target = target + a_body * 10 ** (p["level_db"] / 20) * np.exp(1j * ph2) * carrier_ph
    if "range_straddle" in odd:
        p = odd["range_straddle"]
        drift_db = -p["depth_db"] * 0.5 * (1 - np.cos(2 * np.pi * t / p["period_s"] + rng.uniform(0, 6.3)))
        target = target * 10 ** (drift_db / 20)

    def clutter(rr):
        return _clutter(n, fgrid, rr)

    echo = target + clutter(rng)
    if "phase_noise" in eff:
        p = eff["phase_noise"]
        echo = echo * np.exp(1j * _phase_noise(n, prf, p["skirt_dbc_hz"], p.get("shape", "gauss"), rng))
    noise = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / np.sqrt(2)
    iq = (echo + noise).astype(np.complex64)
    bg = (clutter(rng) + (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / np.sqrt(2)).astype(np.complex64)
    # motor log: 25 Hz, jitter, rounded; a row stamped t holds true(t - lag) / scale
    lag = eff.get("motor_log_lag", {}).get("lag_s", 0.0)
    scale = eff.get("motor_speed_scale", {}).get("scale", 1.0)
    tl0 = np.arange(-1.0, case.duration_s + 1.0, 1 / LOG_HZ)
    tl = np.sort(tl0 + rng.normal(0, 0.004, len(tl0)))
    rpm = np.round(np.array([np.interp(tl - lag, tc, rm) for rm in rev_c]).T * 60.0 / scale).astype(np.float32)
    # track at 20 Hz with a small error
    tt = np.arange(0.0, case.duration_s, 0.05)
    track_r = np.interp(tt, t, r) + rng.normal(0, 0.5, len(tt))
    track_v = np.interp(tt, t, vr) + rng.normal(0, 0.05, len(tt))
    attrs = {
        "schema": "flight-zarr/1",
        "flight_id": case.flight_id,
        "target": "drone",
        "radar_id": case.radar,
        "prf_hz": float(prf),
        "carrier_hz": float(carrier),
        "drone_model": "gen_quad",
        "n_motors": N_MOTORS,
        "n_blades": N_BLADES,
        "blade_length_m": BLADE_M,
        "source": "tests/independent_generator.py",
    }
    flight = Flight(
        attrs=attrs,
        iq=iq,
        track_time_s=tt,
        track_range_m=track_r,
        track_radial_velocity_mps=track_v,
        motors_time_s=tl.astype(np.float64),
        motors_rpm=rpm,
        background_iq=bg,
    )
    truth = {
        "effects": {c: {k: v for k, v in p.items() if k not in ("shape", "motors")} for c, p in eff.items()},
        "oddities": dict(odd),
        "body_doppler_hz": float(np.median(np.abs(-2 * vr / lam))),
        "realized_std_db": realized,
    }  # the std of this flight's own gain path
    return flight, truth


def _clutter(n: int, fgrid: np.ndarray, rng) -> np.ndarray:
    """A stationary line (CNR 45 dB per pulse) with a little wind-blown spread."""
    c0 = 10 ** (45 / 20) * np.exp(1j * rng.uniform(0, 2 * np.pi))
    sp = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) * np.exp(-(fgrid**2) / (4 * 1.5**2))
    wind = np.fft.ifft(sp)
    return c0 + 10 ** (20 / 20) * wind / max(np.abs(wind).std(), 1e-12)


def make_bird(flight_id: str, seed: int, radar: str = "gen_l", duration_s: float = 20.0, snr_db: float = 30.0):
    """A bird flight of this generator's own kind (module docstring) and its truth.

    ``snr_db``: the body line over the noise per bin of a 4096-pulse CPI (Hann gain),
    as for the drones."""
    rng = np.random.default_rng([seed, 7])
    carrier, prf = RADARS[radar]
    lam = C_MPS / carrier
    n = int(round(duration_s * prf))
    t = np.arange(n) / prf
    fgrid = np.fft.fftfreq(n, 1.0 / prf)
    v = rng.choice([-1.0, 1.0]) * rng.uniform(5.0, 14.0)
    vr = v * (1 + 0.05 * np.sin(2 * np.pi * t / rng.uniform(5, 12) + rng.uniform(0, 6.3)))
    r = rng.uniform(400, 1500) + np.cumsum(vr) / prf
    fw = rng.uniform(4.0, 10.0) * (1 + 0.03 * np.sin(2 * np.pi * t / rng.uniform(2, 5)))
    beat = 2 * np.pi * np.cumsum(fw) / prf + rng.uniform(0, 2 * np.pi)
    tip_m = rng.uniform(0.06, 0.14) * np.clip(1.3 * np.sin(beat), -1, 1)  # a clipped sine: dwell at the ends
    w = np.hanning(4096)
    a_body = np.sqrt(10 ** (snr_db / 10) / ((w.sum() ** 2) / (w**2).sum()))
    body = a_body * 10 ** (-WING_DEPTH_DB * 0.5 * (1 - np.cos(beat)) / 20)
    wing = a_body * 10 ** (-rng.uniform(6.0, 12.0) / 20) * np.exp(-1j * 4 * np.pi * tip_m / lam)
    target = (body + wing) * np.exp(-1j * 4 * np.pi * r / lam)
    noise = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / np.sqrt(2)
    iq = (target + _clutter(n, fgrid, rng) + noise).astype(np.complex64)
    bg = (_clutter(n, fgrid, rng) + (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / np.sqrt(2)).astype(
        np.complex64
    )
    tt = np.arange(0.0, duration_s, 0.05)
    attrs = {
        "schema": "flight-zarr/1",
        "flight_id": flight_id,
        "target": "bird",
        "radar_id": radar,
        "prf_hz": float(prf),
        "carrier_hz": float(carrier),
        "source": "tests/independent_generator.py",
    }
    flight = Flight(
        attrs=attrs,
        iq=iq,
        track_time_s=tt,
        track_range_m=np.interp(tt, t, r) + rng.normal(0, 0.5, len(tt)),
        track_radial_velocity_mps=np.interp(tt, t, vr) + rng.normal(0, 0.05, len(tt)),
        background_iq=bg,
    )
    return flight, {"wingbeat_hz": float(np.mean(fw)), "body_doppler_hz": float(np.median(np.abs(-2 * vr / lam)))}
