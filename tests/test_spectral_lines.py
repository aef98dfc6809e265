"""The one reader of a rotor's lines (:mod:`microdoppler.spectra.lines`) against physics:
B identical blades turning at f_rot put lines only at the body Doppler +- k B f_rot
(the HERM comb: spacing B f_rot), none at the other rotation harmonics; a tone's
band holds its whole power (Parseval) and white noise's local floor is its level."""

from __future__ import annotations

import numpy as np
import pytest

from microdoppler.causes.measure import stft_power
from microdoppler.spectra import spectrogram, window
from microdoppler.spectra.lines import band_power, herm_line_hz, herm_line_snr_db, herm_windows, local_floor

PRF_HZ, BODY_HZ, REV_S = 7300.0, 60.0, 40.0


def rotor_echo(n_blades: int, *, rev_s: float = REV_S, seed: int = 0, n: int = 8 * 4096) -> np.ndarray:
    """A body line at BODY_HZ and ``n_blades`` equal blades 360 / B deg apart (each a
    phase swing of 3 rad), plus weak white noise: complex64 [n]."""
    t = np.arange(n) / PRF_HZ
    phase = 2 * np.pi * rev_s * t
    blades = sum(np.exp(1j * 3.0 * np.sin(phase + 2 * np.pi * b / n_blades)) for b in range(n_blades))
    rng = np.random.default_rng(seed)
    noise = 1e-3 * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
    return (np.exp(2j * np.pi * BODY_HZ * t) * (1.0 + blades / n_blades) + noise).astype(np.complex64)


def test_line_k_lies_k_spacings_from_the_body():
    spacing = 2 * REV_S
    for side in (1, -1):
        lines = np.array([herm_line_hz(BODY_HZ, spacing, k, side) for k in range(1, 6)])
        assert lines[0] == BODY_HZ + side * spacing
        np.testing.assert_allclose(np.diff(lines), side * spacing, rtol=1e-12)
    body = np.array([10.0, -30.0])
    np.testing.assert_array_equal(herm_line_hz(body, 100.0, 2, -1), body - 200.0)


@pytest.mark.parametrize("n_blades", [2, 3])
def test_herm_lines_are_spaced_by_blade_count_times_rotation_rate(n_blades):
    spec = spectrogram(rotor_echo(n_blades), PRF_HZ)
    n_t = len(spec.time_s)
    body, rev = np.full(n_t, BODY_HZ), np.full(n_t, REV_S)
    # the HERM lines at body +- k B f_rot stand far above the floor
    _, up, lo = herm_line_snr_db(spec, body, rev, n_blades=n_blades, n_harmonics=2)
    assert np.all(up > 40) and np.all(lo > 40)
    # each window's strongest bin is the line's own, within a bin of k B f_rot
    bin_hz = spec.doppler_hz[1] - spec.doppler_hz[0]
    windows = herm_windows(body, rev, n_blades=n_blades, rotor_half_spread_rev_s=0.0, n_harmonics=2, search_hz=10.0)
    for k, side, centre, half in windows:
        sel = np.abs(spec.doppler_hz - centre[0]) <= half
        peak_hz = spec.doppler_hz[sel][np.argmax(spec.power_db[:, sel], axis=1)]
        assert np.all(np.abs(peak_hz - (BODY_HZ + side * k * n_blades * REV_S)) <= bin_hz)
    # read on the rotation rate's comb (one blade's spacing f_rot), only the multiples
    # of B are lines: orders 1..B-1 read the noise's peaks (median over timesteps
    # < 10 dB), order B the HERM line
    _, up1, lo1 = herm_line_snr_db(spec, body, rev, n_blades=1, n_harmonics=n_blades)
    pair = np.median(np.maximum(up1, lo1), axis=1)
    assert np.all(pair[: n_blades - 1] < 10)
    assert pair[n_blades - 1] > 40


def test_band_power_holds_a_tones_power_and_local_floor_the_noise_level():
    n_fft = 1024
    w = window(n_fft)
    k0 = 100  # the tone on a bin's centre
    t = np.arange(16 * n_fft)
    tone = 2.0 * np.exp(2j * np.pi * k0 * t / n_fft)
    st = stft_power(tone, PRF_HZ, n_fft)
    f_c = k0 * PRF_HZ / n_fft
    # Parseval: sum_k |X_k|^2 = n_fft sum_t |A w_t|^2; Blackman-Harris keeps it within +-4 bins
    p, nb = band_power(st.p[0], st, f_c, 4.5 * st.bin_hz)
    assert nb == 9
    np.testing.assert_allclose(p, n_fft * 4.0 * np.sum(w**2), rtol=1e-6)
    assert band_power(st.p[0], st, -f_c, 4.5 * st.bin_hz)[0] < 1e-6 * p
    # white noise of variance sigma^2 per pulse: every bin's mean power sigma^2 sum(w^2)
    rng = np.random.default_rng(1)
    sigma2 = 3.0
    noise = np.sqrt(sigma2 / 2) * (rng.standard_normal(64 * n_fft) + 1j * rng.standard_normal(64 * n_fft))
    st = stft_power(noise, PRF_HZ, n_fft)
    fl = np.array([local_floor(row, st, 0.0, 20.0, 1500.0) for row in st.p])
    assert abs(fl.mean() / (sigma2 * np.sum(w**2)) - 1) < 0.05
