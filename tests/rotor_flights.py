"""Drone flights made with the paper's eq. (1)/(2) directly (no emulator) for the rotor
speed tests (test_rotorspeed.py, test_rotorfit.py), and their truth per CPI.

Truth per CPI is the true speed averaged over the CPI with the window's power profile
(what a periodogram line measures: the first moment of a spectrogram line is the
window^2-weighted mean of its instantaneous frequency).
"""

from __future__ import annotations

import numpy as np
from scipy.signal.windows import blackmanharris

from microdoppler.diagnosis.measure import cpi_average
from microdoppler.io.flightzarr import Flight
from microdoppler.rotors.speed import estimate_rotor_speeds
from microdoppler.synthesis import model as synthesis

PRF = 7300.0
CARRIER = 1.35e9
LAM = 299_792_458.0 / CARRIER
N_FFT = 4096


def cpi_truth(rev_t_s, rev_s, cpi_t_s):
    """Window^2-weighted mean of each motor's speed over each CPI [rev/s]."""
    w = blackmanharris(N_FFT, sym=False)
    return np.column_stack([cpi_average(rev_t_s, rev_s[:, m], cpi_t_s, w, PRF) for m in range(rev_s.shape[1])])


def synthetic_flight(
    rev_s,
    *,
    n_blades=2,
    blade_length_m=0.19,
    first_sideband_db=8.0,
    snr_db=45.0,
    radial_velocity_mps=-5.0,
    alpha_s=0.002,
    seed=0,
    blades_until_s=None,
    blades_drop=None,
) -> Flight:
    """A drone flight made with the paper's eq. (1)/(2) directly (no emulator): body on
    a constant-velocity track, blades ``first_sideband_db`` below it (before the alpha
    envelope), white noise for a body-line SNR of ``snr_db`` in the 4096-point
    Blackman-Harris periodogram; ``blades_until_s``: the blades fall silent then;
    ``blades_drop`` = (time [s], dB): the blades are that much weaker from then on."""
    n = rev_s.shape[0]
    dur = n / PRF
    track = synthesis.Track.constant_velocity(1500.0, radial_velocity_mps, dur)
    table = synthesis.BladeModel(n_blades, blade_length_m, LAM).table().astype(complex)
    c_b = np.abs(np.fft.fft(table))[n_blades] / synthesis.TABLE_SIZE

    def blade_gain(i0, i1, t_s, x):
        if blades_until_s is not None:
            x[t_s >= blades_until_s] = 0
        if blades_drop is not None:
            x[t_s >= blades_drop[0]] *= 10 ** (-blades_drop[1] / 20)

    hooked = blades_until_s is not None or blades_drop is not None
    config = synthesis.SynthesisConfig.of(
        prf_hz=PRF,
        wavelength_m=LAM,
        n_blades=n_blades,
        blade_length_m=blade_length_m,
        scaling=synthesis.Scaling(1.0, 10 ** (-first_sideband_db / 20) / c_b, alpha_s),
        extensions=synthesis.ModelExtensions(blade_hook=blade_gain if hooked else None),
    )
    iq = synthesis.synthesize(config, track, rev_s, seed=seed)
    w = blackmanharris(N_FFT, sym=False)
    noise = w.sum() ** 2 / (w**2).sum() / 10 ** (snr_db / 10)  # body peak / noise per bin = snr
    synthesis.add_noise(iq, noise, seed + 1)
    tt = np.linspace(0.0, dur, 40)
    attrs = dict(
        schema="flight-zarr/1",
        flight_id="synthetic",
        target="drone",
        radar_id="synthetic",
        prf_hz=PRF,
        carrier_hz=CARRIER,
        drone_model="test_quad",
        n_motors=int(rev_s.shape[1]),
        n_blades=int(n_blades),
        blade_length_m=float(blade_length_m),
    )
    return Flight(attrs, iq, tt, 1500.0 + radial_velocity_mps * tt, np.full(len(tt), radial_velocity_mps))


def rel_errors(est, truth):
    """|mean speed / true mean - 1| and |ranked speeds / sorted truth - 1| per CPI."""
    mean_err = np.abs(est.common_rev_s / truth.mean(axis=1) - 1)
    rotor_err = np.abs(est.speeds_rev_s / np.sort(truth, axis=1) - 1)
    return mean_err, rotor_err


# ---------------------------------------------------------------- signals made without the emulator


def crowded_rotors(rng, t):
    """Four rotors within a bin or two of each other (speeds 0.8 % apart, rms) whose
    speeds wobble by 0.5-3 % over 0.5-2 s: [len(t), 4] rev/s."""
    base = rng.uniform(60.0, 95.0)
    off = np.sort(rng.normal(0.0, 0.008, 4))
    wobble = rng.uniform(0.005, 0.03) * np.sin(
        2 * np.pi * t[:, None] / rng.uniform(0.5, 2.0) + rng.uniform(0, 2 * np.pi, 4)
    )
    return base * (1 + off + wobble)


def crowded_z_scores(seed, n_flights, draw_kwargs, select):
    """6 s flights of :func:`crowded_rotors` (each flight's :func:`synthetic_flight`
    arguments from ``draw_kwargs(rng)``): |error| / sigma of the mean and of each ranked
    rotor in the CPIs ``select(est)``, and each flight's share of selected CPIs."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(6 * PRF)) / PRF
    z_mean, z_rotor, shares = [], [], []
    for _ in range(n_flights):
        rev = crowded_rotors(rng, t)
        fl = synthetic_flight(rev, seed=int(rng.integers(1000)), **draw_kwargs(rng))
        est = estimate_rotor_speeds(fl)
        assert est.ok, est.reason
        truth = cpi_truth(t, rev, est.time_s)
        sel = select(est)
        shares.append(float(sel.mean()))
        z_mean += list(np.abs(est.common_rev_s - truth.mean(axis=1))[sel] / est.common_std_rev_s[sel])
        z_rotor += list((np.abs(est.speeds_rev_s - np.sort(truth, axis=1)) / est.speeds_std_rev_s)[sel].ravel())
    return z_mean, z_rotor, shares
