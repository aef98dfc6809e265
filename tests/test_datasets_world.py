"""A tiny measured-like world for the dataset tests (no emulator needed).

Drones are eq. (2) with stronger, asymmetric sidebands than the paper's model (an
envelope gain of +4 dB above the body, -2 dB below, a different alpha and the true
rotor rates jittering around the log), so the twin's calibration is a real fit.
Every flight has clutter + white noise and a ``background/iq`` recorded with another
noise seed. One Inspire flight has no motor log.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from microdoppler.io.flightzarr import Flight, write_flight
from microdoppler.synthesis.radar import DRONE_MODELS
from microdoppler.synthesis.model import ModelExtensions, Scaling, SynthesisConfig, Track, add_noise, synthesize

PRF_HZ = 7300.0
CARRIER_HZ = 1.35e9
WAVELENGTH_M = 299_792_458.0 / CARRIER_HZ


def _background(n, seed, clutter_power=30.0):
    rng = np.random.default_rng(seed)
    # slow clutter: low-passed complex random walk at zero Doppler
    k = np.exp(-np.arange(0, 4000) / 800.0)
    w = rng.standard_normal(n + len(k)) + 1j * rng.standard_normal(n + len(k))
    c = np.convolve(w, k / np.sqrt(np.sum(k**2)), mode="valid")[:n] * np.sqrt(clutter_power / 2)
    x = c.astype(np.complex64)
    return add_noise(x, 1.0, seed + 1)


def make_flight(
    fid,
    target,
    *,
    duration_s,
    seed,
    drone_model=None,
    radar_id="r1",
    range_m=1500.0,
    v_mps=-8.0,
    with_log=True,
    s_body=1.0,
    s_blade=4.0,
    alpha_s=0.004,
):
    rng = np.random.default_rng(seed)
    n = int(duration_s * PRF_HZ)
    t_track = np.linspace(0, duration_s, 50)
    rng_m = range_m + v_mps * t_track + 3 * np.sin(t_track / 3)
    track = Track(t_track, rng_m)
    attrs = dict(
        schema="flight-zarr/1", flight_id=fid, target=target, radar_id=radar_id, prf_hz=PRF_HZ, carrier_hz=CARRIER_HZ
    )
    mt = mr = None
    if target == "drone":
        dm = DRONE_MODELS[drone_model]
        attrs.update(
            drone_model=drone_model, n_motors=dm.n_motors, n_blades=dm.n_blades, blade_length_m=dm.blade_length_m
        )
        f0 = dm.typical_motor_hz * (1 + 0.04 * rng.standard_normal(dm.n_motors))
        t = np.arange(n) / PRF_HZ
        slow = 1 + 0.03 * np.sin(2 * np.pi * t[:, None] / 7.0 + rng.uniform(0, 6, dm.n_motors))
        true_rev = (f0 * slow).astype(np.float32)
        gain = ModelExtensions(envelope_gain=lambda f: np.where(f > 0, 10 ** (4 / 20), 10 ** (-2 / 20)))
        config = SynthesisConfig.of(
            prf_hz=PRF_HZ,
            wavelength_m=WAVELENGTH_M,
            n_blades=dm.n_blades,
            blade_length_m=dm.blade_length_m,
            scaling=Scaling(s_body, s_blade, alpha_s),
            extensions=gain,
        )
        iq = synthesize(config, track, true_rev, seed=seed)
        if with_log:
            mt = np.arange(0, duration_s, 1 / 30.0) + rng.uniform(-0.003, 0.003)
            mt = np.sort(np.clip(mt, 0, None))
            idx = np.clip((mt * PRF_HZ).astype(int), 0, n - 1)
            mr = np.round(true_rev[idx] * 60).astype(np.float32)
    else:
        config = SynthesisConfig.of(
            prf_hz=PRF_HZ, wavelength_m=WAVELENGTH_M, n_blades=2, blade_length_m=0.1, scaling=Scaling(s_body, 0.0, 0.0)
        )
        iq = synthesize(config, track, np.zeros((n, 1), np.float32), seed=seed)
        t = np.arange(n) / PRF_HZ
        iq *= (1 + 0.4 * np.sin(2 * np.pi * 5.0 * t)).astype(np.float32)
    iq = iq + _background(n, seed + 100)
    bg = _background(n, seed + 200)
    fl = Flight(
        attrs=attrs,
        iq=iq.astype(np.complex64),
        track_time_s=t_track,
        track_range_m=rng_m,
        track_radial_velocity_mps=track.radial_velocity_at(t_track),
        motors_time_s=mt,
        motors_rpm=mr,
        background_iq=bg,
    )
    return fl


#: (flight_id, target, drone_model, radar, with_log, s_body, s_blade, v_mps)
WORLD = [
    ("ins1", "drone", "inspire2", "r1", True, 1.0, 4.0, -8.0),
    ("ins2", "drone", "inspire2", "r2", True, 0.5, 3.0, 6.0),
    ("ins3", "drone", "inspire2", "r1", False, 1.0, 4.0, -5.0),
    ("mat1", "drone", "matrice300", "r1", True, 1.0, 5.0, -6.0),
    ("mat2", "drone", "matrice300", "r2", True, 0.7, 3.0, 7.0),
    ("mini1", "drone", "mini2", "r1", True, 0.8, 1.0, -9.0),
    ("bird1", "bird", None, "r1", False, 0.3, 0.0, -10.0),
    ("bird2", "bird", None, "r2", False, 0.2, 0.0, 9.0),
]


def make_world(out_dir, *, duration_s=12.0, seed=11) -> Path:
    """Write the world's flight stores into ``out_dir``; returns it."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    for i, (fid, target, model, radar, log, sb, sbl, v) in enumerate(WORLD):
        fl = make_flight(
            fid,
            target,
            duration_s=duration_s,
            seed=seed + 17 * i,
            drone_model=model,
            radar_id=radar,
            with_log=log,
            s_body=sb,
            s_blade=sbl,
            v_mps=v,
        )
        write_flight(out_dir / f"{fid}.zarr", fl)
    return out_dir
