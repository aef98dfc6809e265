"""Drone flight and motor dynamics, and the motor-log writer.

Flight path: a stadium-shaped loop (two straight legs joined by half circles) at a
fixed height, flown forward or reverse at a commanded speed with small speed
variations; the hand-flown Mini wanders around the plan (noisier track).

Motor model (at the control rate :data:`CONTROL_HZ`, interpolated to pulse rate):
the thrust vector must balance gravity, acceleration and aerodynamic drag in the
gusty wind, so the collective speed follows omega_hover * sqrt(|T| / (m g)). Each
motor m (arm angle psi_m, spin s_m) adds a relative command

    u_m = delta_m + p(t) cos psi_m + r(t) sin psi_m + y(t) s_m

with delta_m a static per-motor offset (centre of gravity, motor/propeller spread),
p, r pitch and roll moments (attitude changes, a forward-flight trim that loads the
rear motors, gust turbulence and controller jitter as OU processes) and y the yaw
moment (turns). The ESC follows with a first-order lag of :data:`MOTOR_TAU_S`.

The log writer samples the true speeds as a drone writes them: at a nominal rate
(30 Hz Inspire, 20 Hz Matrice) with timestamp jitter and dropped rows, rounded to
1 rpm, on the radar clock; the ``motor_log_lag`` and ``motor_speed_scale`` knobs act
here only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from .knobs import ou_process

CONTROL_HZ = 200.0
MOTOR_TAU_S = 0.05
GRAVITY_MPS2 = 9.81
#: seconds of motor history generated before t=0 and after the end (log margins)
PAD_S = 2.0


@dataclass(frozen=True)
class DroneDynamics:
    """Per-model airframe numbers.

    Parameters
    ----------
    hover_rev_s : float
        Typical hover rotor speed [rev/s].
    mass_kg : float
    drag_coeff : float
        Quadratic drag coefficient c in F = c |v_air| v_air [kg/m].
    static_spread : float
        Standard deviation of the static per-motor offset (relative).
    turbulence : float
        Relative moment noise per m/s of gust strength.
    log_rate_hz : float
        Motor-log rate (0 = no log).
    hand_flown : bool
        Noisy, wandering path (the Mini).
    """

    hover_rev_s: float
    mass_kg: float
    drag_coeff: float
    static_spread: float
    turbulence: float
    log_rate_hz: float
    hand_flown: bool = False


DYNAMICS = {
    "inspire2": DroneDynamics(80.0, 3.4, 0.09, 0.06, 0.02, 30.0),
    "matrice300": DroneDynamics(60.0, 6.3, 0.14, 0.05, 0.018, 20.0),
    "mini2": DroneDynamics(165.0, 0.25, 0.012, 0.06, 0.025, 0.0, hand_flown=True),
}

#: arm angles (X frame) and spin directions of the four motors
ARM_RAD = np.deg2rad([45.0, 135.0, 225.0, 315.0])
SPIN = np.array([1.0, -1.0, 1.0, -1.0])


@dataclass
class DronePath:
    """Drone state on the control grid ``t_s`` (starting at -PAD_S)."""

    t_s: np.ndarray
    pos_m: np.ndarray  # [n, 3] radar at origin, z up
    vel_mps: np.ndarray  # [n, 3]
    acc_mps2: np.ndarray  # [n, 3]

    @property
    def range_m(self) -> np.ndarray:
        return np.linalg.norm(self.pos_m, axis=1)

    @property
    def radial_velocity_mps(self) -> np.ndarray:
        return np.einsum("ij,ij->i", self.pos_m, self.vel_mps) / self.range_m


def loop_path(
    duration_s: float,
    *,
    mean_range_m: float,
    height_m: float,
    speed_mps: float,
    direction: int,
    hand_flown: bool,
    rng: np.random.Generator,
    straight: bool = False,
    wander_m: float = 5.0,
) -> DronePath:
    """A stadium loop around a centre ``mean_range_m`` from the radar, or with
    ``straight`` one long leg within 17 deg of the line of sight through that centre
    (receding for ``direction`` +1): no turns, the body Doppler never nears zero.
    ``wander_m`` is the std of a hand-flown drone's smooth deviations from the plan."""
    dt = 1.0 / CONTROL_HZ
    t = np.arange(-PAD_S, duration_s + PAD_S + dt, dt)
    n = len(t)
    az0 = rng.uniform(-np.pi / 4, np.pi / 4)
    centre = mean_range_m * np.array([np.cos(az0), np.sin(az0)])
    # turn radius and leg orientation set the time the body spends in the 15 Hz notch
    # at the turns, which dominates a flight's SNR spread: calibrated to Table III's
    # per-flight std (Inspire 7.0, Matrice 7.5, Mini 5.7 dB; docs/experiments.md)
    radius = rng.uniform(15.0, 40.0)
    leg = rng.uniform(100.0, 400.0)
    # legs laid out roughly along the line of sight (trials want a Doppler signature)
    orient = az0 + rng.uniform(-0.25, 0.25)
    vs = speed_mps * (1 + _smooth(ou_process(n, dt, 0.15 if hand_flown else 0.06, 3.0, rng), 2.0))
    vs = np.maximum(vs, 0.5)
    if straight:
        leg = float(np.sum(vs) * dt) + 10.0
        radius = 1e-3
        orient = az0 + rng.uniform(-0.3, 0.3) + (0.0 if direction > 0 else np.pi)
        s = 5.0 + np.cumsum(vs) * dt
        s -= s[n // 2] - leg / 2  # centre of the leg at mid-flight
        s = np.clip(s, 0.0, leg - 1e-6)
    else:
        s = rng.uniform(0, 2 * leg + 2 * np.pi * radius) + direction * np.cumsum(vs) * dt
    perim = 2 * leg + 2 * np.pi * radius
    s = np.mod(s, perim)
    # stadium in local coordinates: leg along x from -leg/2..leg/2 at y=-radius, then arc...
    x = np.empty(n)
    y = np.empty(n)
    a1 = s < leg
    x[a1], y[a1] = -leg / 2 + s[a1], -radius
    a2 = (s >= leg) & (s < leg + np.pi * radius)
    th = (s[a2] - leg) / radius - np.pi / 2
    x[a2], y[a2] = leg / 2 + radius * np.cos(th), radius * np.sin(th)
    a3 = (s >= leg + np.pi * radius) & (s < 2 * leg + np.pi * radius)
    x[a3], y[a3] = leg / 2 - (s[a3] - leg - np.pi * radius), radius
    a4 = s >= 2 * leg + np.pi * radius
    th = (s[a4] - 2 * leg - np.pi * radius) / radius + np.pi / 2
    x[a4], y[a4] = -leg / 2 + radius * np.cos(th), radius * np.sin(th)
    if hand_flown:  # the pilot's wander: smooth (2 s) deviations of wander_m from the plan
        kw = np.hanning(int(2.0 * CONTROL_HZ) | 1)
        kw /= kw.sum()
        x += np.convolve(ou_process(n, dt, wander_m, 6.0, rng), kw, mode="same")
        y += np.convolve(ou_process(n, dt, wander_m, 6.0, rng), kw, mode="same")
    c, sn = np.cos(orient), np.sin(orient)
    px = centre[0] + c * x - sn * y
    py = centre[1] + sn * x + c * y
    pz = height_m + _smooth(ou_process(n, dt, 3.0 if hand_flown else 1.5, 4.0, rng), 2.0)
    pos = np.column_stack([px, py, pz])
    # smooth the corners of the piecewise path (and the wrap), as the autopilot does
    k = int(0.5 * CONTROL_HZ)
    ker = np.hanning(2 * k + 1)
    ker /= ker.sum()
    pos = np.column_stack([np.convolve(np.pad(pos[:, i], k, mode="edge"), ker, mode="valid") for i in range(3)])
    vel = np.gradient(pos, dt, axis=0)
    acc = np.gradient(vel, dt, axis=0)
    return DronePath(t, pos, vel, acc)


@dataclass
class MotorTruth:
    """True motor speeds on the control grid: ``rev_s`` [n, 4] at ``t_s``."""

    t_s: np.ndarray
    rev_s: np.ndarray

    def at(self, t_s: np.ndarray) -> np.ndarray:
        """Linear interpolation to times ``t_s`` [s]: float64 [len(t_s), 4]."""
        return np.column_stack([np.interp(t_s, self.t_s, self.rev_s[:, m]) for m in range(self.rev_s.shape[1])])


def motor_speeds(
    path: DronePath, dyn: DroneDynamics, *, wind_mps: float, rng: np.random.Generator, hover_scale: float = 1.0
) -> MotorTruth:
    """True per-motor rotation rates [rev/s] along ``path`` in a gusty wind."""
    t = path.t_s
    n = len(t)
    dt = 1.0 / CONTROL_HZ
    wdir = rng.uniform(0, 2 * np.pi)
    gust_sd = 0.3 + 0.25 * wind_mps

    def gust(sd, tau):  # OU smoothed over 0.5 s: gusts have no infinitely fast edges
        return _smooth(ou_process(n, dt, sd, tau, rng), 0.5)

    wind = np.column_stack(
        [
            wind_mps * np.cos(wdir) + gust(gust_sd, 3.0),
            wind_mps * np.sin(wdir) + gust(gust_sd, 3.0),
            gust(0.4 * gust_sd, 1.5),
        ]
    )
    v_air = path.vel_mps - wind
    sp_air = np.linalg.norm(v_air, axis=1, keepdims=True)
    thrust = dyn.mass_kg * (path.acc_mps2 + np.array([0, 0, GRAVITY_MPS2])) + dyn.drag_coeff * sp_air * v_air
    tmag = np.linalg.norm(thrust, axis=1)
    collective = np.sqrt(tmag / (dyn.mass_kg * GRAVITY_MPS2))
    # body frame: x forward along the heading (velocity over ground), y left
    heading = np.unwrap(np.arctan2(path.vel_mps[:, 1], path.vel_mps[:, 0]))
    tilt = thrust[:, :2] / tmag[:, None]  # horizontal thrust direction ~ tilt angles
    ch, sh = np.cos(heading), np.sin(heading)
    pitch = -(ch * tilt[:, 0] + sh * tilt[:, 1])  # nose-down forward flight is negative pitch
    roll = -sh * tilt[:, 0] + ch * tilt[:, 1]
    # moments: angular acceleration of the attitude, a forward-flight trim (rear motors
    # work harder), turbulence and controller jitter
    k_att = 0.002
    pdd = np.gradient(np.gradient(_smooth(pitch, 0.3), dt), dt)
    rdd = np.gradient(np.gradient(_smooth(roll, 0.3), dt), dt)
    fwd = ch * v_air[:, 0] + sh * v_air[:, 1]
    turb = dyn.turbulence * gust_sd
    p_mom = k_att * pdd + 0.004 * fwd + ou_process(n, dt, turb, 0.4, rng) + ou_process(n, dt, 0.004, 0.03, rng)
    r_mom = k_att * rdd + ou_process(n, dt, turb, 0.4, rng) + ou_process(n, dt, 0.004, 0.03, rng)
    yaw_rate = np.gradient(heading, dt)
    y_mom = 0.01 * np.gradient(yaw_rate, dt) * 0.05 + ou_process(n, dt, 0.5 * turb, 1.0, rng) + rng.normal(0, 0.01)
    delta = rng.normal(0, dyn.static_spread, 4)
    delta -= delta.mean() - rng.normal(0, 0.3 * dyn.static_spread)
    u = (
        delta[None, :]
        + p_mom[:, None] * np.cos(ARM_RAD)[None, :]
        + r_mom[:, None] * np.sin(ARM_RAD)[None, :]
        + y_mom[:, None] * SPIN[None, :]
    )
    cmd = dyn.hover_rev_s * hover_scale * collective[:, None] * (1 + np.clip(u, -0.5, 0.5))
    a = np.exp(-dt / MOTOR_TAU_S)
    zi = cmd[0] * a
    rev = lfilter([1 - a], [1, -a], cmd, axis=0, zi=zi[None, :])[0]
    return MotorTruth(t, rev)


def _smooth(x: np.ndarray, window_s: float) -> np.ndarray:
    k = max(1, int(window_s * CONTROL_HZ / 2))
    w = np.hanning(2 * k + 1)
    w /= w.sum()
    return np.convolve(np.pad(x, k, mode="edge"), w, mode="valid")


def write_log(
    truth: MotorTruth,
    duration_s: float,
    rate_hz: float,
    rng: np.random.Generator,
    *,
    lag_s: float = 0.0,
    scale: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """The motor log as the drone writes it.

    Returns
    -------
    time_s : ndarray, float64 [n_log]
        Row stamps on the radar clock [s], jittered, strictly increasing.
    rpm : ndarray, float32 [n_log, 4]
        Logged speeds, rounded to 1 rpm; a row stamped t holds true(t - lag_s) / scale.
    """
    period = 1.0 / rate_hz
    t0 = -rng.uniform(0.2, 1.0)
    t1 = duration_s + rng.uniform(0.2, 1.0)
    k = np.arange(int(np.floor((t1 - t0) / period)) + 1)
    t = t0 + k * period + rng.normal(0, 0.08 * period, len(k))
    keep = rng.uniform(size=len(k)) > 0.01  # occasional dropped rows
    t = np.sort(t[keep])
    t = t[np.concatenate([[True], np.diff(t) > 1e-4])]
    src = np.clip(t - lag_s, truth.t_s[0], truth.t_s[-1])
    rpm = np.round(truth.at(src) * 60.0 / scale).astype(np.float32)
    return t.astype(np.float64), rpm
