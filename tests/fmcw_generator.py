"""An independent generator of raw FMCW recordings of a drone (beat signals).

It tests ``microdoppler import`` on FMCW cubes that the project did not shape: it
imports only numpy and shares no code with ``microdoppler`` (not the emulator, the
synthesis, nor :mod:`microdoppler.importing.fmcw`). Its physics, written out per scatterer:

- A sawtooth FMCW radar: chirp ``m`` starts at ``t_m = m / chirp_rate_hz``; its sampled
  part sweeps ``bandwidth_hz`` linearly over ``n_samples`` samples at
  ``sample_rate_hz``, from ``f0 = carrier_hz - bandwidth_hz / 2`` (so ``carrier_hz``
  is the sweep's centre), slope ``S = bandwidth_hz * sample_rate_hz / n_samples``.
- A point scatterer at two-way delay ``tau(t)`` gives, after the transmitted sweep is
  multiplied by the conjugate of the received one (the usual dechirp; a real mixer
  keeps the real part), the beat
  ``a exp(j 2 pi (f0 tau + S tau t_f - S tau^2 / 2))`` at fast time ``t_f`` in the
  chirp, with ``tau = (2 R(t) + d_c) / c`` evaluated at the sample's own time
  ``t_m + t_f`` (the target moves within a chirp), ``d_c`` the extra path to receive
  channel ``c`` (a line of channels ``lambda / 2`` apart, every scatterer at
  ``angle_deg``; the tiny cross term ``S tau d_c`` is taken at the point's mean delay).
- The drone: a body point at range ``range0_m + radial_speed_mps * t``; rotors whose
  hubs sit a little off the body along the line of sight, each with ``n_blades``
  blades of ``blade_points`` point scatterers from 15 % of the blade to its tip, turning
  at the rotor's own rate in a plane tilted ``elevation_deg`` from the line of
  sight: a point at radius ``r`` and angle ``theta`` is ``r cos(theta) cos(el)``
  further away. So each rotor adds lines at the body Doppler plus multiples of
  ``n_blades * rate`` (equal blades), spread out to the blade-tip Doppler.
- Static clutter: point scatterers at fixed ranges (one on the drone's path);
  receiver noise: white, per channel, of standard deviation ``noise_std`` per
  real component.

The truth it returns (per chirp): the body's range, radial velocity and Doppler
``-2 v / lambda`` (flight-zarr's sign: approaching -> positive), with
``lambda = c / carrier_hz``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

C_MPS = 299792458.0


@dataclass(frozen=True)
class FmcwScene:
    """One FMCW recording to generate (units in the names)."""

    seed: int = 0
    carrier_hz: float = 5.8e9
    bandwidth_hz: float = 150e6
    sample_rate_hz: float = 2.0e6
    n_samples: int = 64
    chirp_rate_hz: float = 8000.0
    duration_s: float = 1.5
    n_channels: int = 2
    angle_deg: float = 20.0
    real: bool = False
    range0_m: float = 14.2
    radial_speed_mps: float = -2.5
    body_amp: float = 1.0
    rotor_rev_s: tuple = (71.0, 83.0, 97.0, 109.0)
    rotor_offsets_m: tuple = (-0.25, -0.1, 0.1, 0.25)
    n_blades: int = 2
    blade_length_m: float = 0.12
    blade_points: int = 4
    blade_amp: float = 0.06
    elevation_deg: float = 15.0
    clutter: tuple = ((9.6, 20.0), (12.4, 8.0), (23.0, 30.0))
    noise_std: float = 0.05
    extra: dict = field(default_factory=dict)

    @property
    def wavelength_m(self) -> float:
        return C_MPS / self.carrier_hz

    @property
    def n_chirps(self) -> int:
        return int(round(self.duration_s * self.chirp_rate_hz))

    @property
    def range_bin_m(self) -> float:
        return C_MPS / (2 * self.bandwidth_hz)


def _beat(scene: FmcwScene, r_m: np.ndarray, amp: complex) -> np.ndarray:
    """Beat of one point at range ``r_m`` [n_chirps, n_samples] (metres, at each
    sample's time) in every channel: [n_chirps, n_samples, n_channels]."""
    f0 = scene.carrier_hz - scene.bandwidth_hz / 2
    slope = scene.bandwidth_hz * scene.sample_rate_hz / scene.n_samples
    tau = 2 * r_m / C_MPS
    tf = np.arange(scene.n_samples)[None, :] / scene.sample_rate_hz
    base = amp * np.exp(2j * np.pi * (f0 * tau + slope * tau * tf - slope * tau**2 / 2))
    # channel c: delay tau + d_c; the factor is exact but for the cross term S tau d_c,
    # taken at the point's mean delay (its change over the recording is < 1e-4 rad)
    tbar = float(np.mean(tau))
    out = np.empty(base.shape + (scene.n_channels,), np.complex128)
    for ch in range(scene.n_channels):
        d = ch * scene.wavelength_m / 2 * np.sin(np.radians(scene.angle_deg)) / C_MPS
        out[..., ch] = base * np.exp(2j * np.pi * (f0 * d + slope * d * tf - slope * (2 * tbar * d + d * d) / 2))
    return out


def generate(scene: FmcwScene) -> tuple[np.ndarray, dict]:
    """The beat cube and the truth.

    Returns
    -------
    cube : ndarray, complex64 or float32 [n_chirps, n_samples, n_channels]
    truth : dict
        ``time_s`` [n_chirps] (chirp starts), ``range_m``, ``radial_velocity_mps``,
        ``body_doppler_hz`` of the body per chirp; ``rotor_rev_s``, ``n_blades``,
        ``wavelength_m``, ``range_bin_m``.
    """
    rng = np.random.default_rng(scene.seed)
    m, n = scene.n_chirps, scene.n_samples
    t = np.arange(m)[:, None] / scene.chirp_rate_hz + np.arange(n)[None, :] / scene.sample_rate_hz
    body = scene.range0_m + scene.radial_speed_mps * t
    el = np.radians(scene.elevation_deg)
    radii = np.linspace(0.15, 1.0, scene.blade_points) * scene.blade_length_m
    phase0 = rng.uniform(0, 2 * np.pi, len(scene.rotor_rev_s))
    cube = _beat(scene, body, scene.body_amp)
    for k, rate in enumerate(scene.rotor_rev_s):
        hub = body + scene.rotor_offsets_m[k]
        for b in range(scene.n_blades):
            theta = 2 * np.pi * rate * t + phase0[k] + 2 * np.pi * b / scene.n_blades
            for r in radii:
                cube += _beat(scene, hub + r * np.cos(theta) * np.cos(el), scene.blade_amp / scene.blade_points)
    for r_c, a_c in scene.clutter:
        cube += _beat(scene, np.full((1, 1), r_c), a_c * np.exp(1j * rng.uniform(0, 2 * np.pi)))
    if scene.real:
        out = cube.real + scene.noise_std * rng.standard_normal(cube.shape)
        out = out.astype(np.float32)
    else:
        out = cube + scene.noise_std * (rng.standard_normal(cube.shape) + 1j * rng.standard_normal(cube.shape))
        out = out.astype(np.complex64)
    t0 = np.arange(m) / scene.chirp_rate_hz
    v = np.full(m, scene.radial_speed_mps)
    truth = {
        "time_s": t0,
        "range_m": scene.range0_m + scene.radial_speed_mps * t0,
        "radial_velocity_mps": v,
        "body_doppler_hz": -2 * v / scene.wavelength_m,
        "rotor_rev_s": tuple(scene.rotor_rev_s),
        "n_blades": scene.n_blades,
        "wavelength_m": scene.wavelength_m,
        "range_bin_m": scene.range_bin_m,
    }
    return out, truth
