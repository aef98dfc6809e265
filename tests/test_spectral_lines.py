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


def _rotation_line_powers_line_by_line(st, f_body_hz, motor_rev_s, valid, k_max, floor, guard_hz, raised_db):
    """The rotation lines' powers the plain way (the implementation before the
    vectorised one, kept as the oracle): a bin mask marked for every line in turn."""
    from microdoppler.causes.config import DiagnosisConfig
    from microdoppler.causes.measure import DB, noise_power_factor
    from microdoppler.spectra.lines import band_spans, bins_near

    n_t = motor_rev_s.shape[0]
    df, nyq = st.bin_hz, st.f_hz[-1]
    kappa = noise_power_factor(st.window)
    P, V, W = (np.full((n_t, k_max, 2), np.nan) for _ in range(3))
    R = np.zeros((n_t, k_max, 2), int)
    for i in np.flatnonzero(valid):
        fr = motor_rev_s[i]
        for k in range(1, k_max + 1):
            half = k * fr * DiagnosisConfig().rotor_wander_rel + 1.5 * df
            for s, sg in enumerate((1.0, -1.0)):
                cs = herm_line_hz(f_body_hz[i], fr, k, sg)
                near_orders = [herm_line_hz(f_body_hz[i], fr, k2, sg) for k2 in range(max(0, k - 2), k + 3) if k2 != k]
                others = bins_near(st, np.concatenate(near_orders), np.tile(half, len(near_orders)))
                taken = np.concatenate([[0], np.cumsum(others)])
                lo, hi = band_spans(st, cs, half)
                hit = (lo <= hi) & (taken[np.maximum(hi, lo - 1) + 1] - taken[lo] > 0)
                ok = (np.abs(cs) + half < nyq) & (np.abs(cs) > guard_hz + half) & ~hit
                clear = np.flatnonzero(ok).tolist()
                if not clear:
                    continue
                mine = bins_near(st, cs[clear], half[clear])
                near = bins_near(st, [cs.mean()], [0.5 * fr.mean()]) & ~mine & ~others & ~bins_near(st, cs, half)
                if near.sum() < 4:
                    continue
                fl = float(np.median(st.p[i, near]) / np.log(2.0))
                if DB * np.log(fl / floor[i]) > raised_db:
                    continue
                nb = int(mine.sum())
                P[i, k - 1, s] = float(st.p[i, mine].sum()) - nb * fl
                V[i, k - 1, s] = kappa * nb * fl**2
                W[i, k - 1, s] = 2 * kappa * fl
                R[i, k - 1, s] = len(clear)
    return P, V, W, R


@pytest.mark.parametrize("n_motors, spread", [(4, 0.03), (2, 0.0), (6, 0.12)])
def test_rotation_line_powers_equal_the_line_by_line_reading(n_motors, spread):
    """The vectorised rotation-line powers (every order, side and rotor of a CPI at once)
    are the line-by-line reading's, bit for bit: rotors close enough for their lines to
    overlap (cleared lines), lines past the PRF's edge and in the clutter guard."""
    from microdoppler.causes.measure import rotation_line_powers

    rng = np.random.default_rng(n_motors)
    st = stft_power(rotor_echo(2, rev_s=90.0, seed=n_motors, n=6 * 4096), PRF_HZ, 4096)
    n_t = len(st.t_s)
    rev = 90.0 * (1 + spread * rng.uniform(-1, 1, (n_t, n_motors)))
    body = BODY_HZ + rng.normal(0, 5, n_t)
    valid = np.ones(n_t, bool)
    valid[1] = False
    floor = np.median(st.p, axis=1) / np.log(2.0)
    args = (st, body, rev, valid, 2, 24, floor)
    got = rotation_line_powers(*args, clutter_guard_hz=20.0, raised_floor_db=6.0)
    want = _rotation_line_powers_line_by_line(st, body, rev, valid, 24, floor, 20.0, 6.0)
    for g, w in zip(got, want):
        assert g.dtype == w.dtype and g.tobytes() == w.tobytes()
    assert np.isfinite(got[0]).sum() > 20 and np.isnan(got[0][valid]).any()
