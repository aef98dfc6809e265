"""Physics of the drone micro-Doppler simulator (eq. 1 and eq. 2).

Common scene: L-band (1.35 GHz, lambda = 0.222 m), PRF 7300 Hz, 2 blades, body at
500 m approaching at 5 m/s (f_body = +45.0 Hz). Spectra are the paper's
Blackman-Harris STFT (4096, 50 %), all bins, averaged over timesteps.

Visibility threshold (sideband-count tests): a line is *visible* when its peak is
13 dB above the median noise floor of the spectrogram (single-bin detection at a
false-alarm rate of ~1e-6 needs ~13 dB). Noise is added at a per-pulse SNR of 13 dB
(body power per pulse / noise power per pulse), i.e. a body line ~46 dB above the
floor after the CPI's coherent gain of 10 log10(4096 / 2.0 bins ENBW) = 33 dB: a
short-range, high-SNR look. The threshold therefore sits ~33 dB below the body line.
In eq. (1) with S_body = S_blade = 1 the Inspire blade's sideband pairs n = 1..4 lie
27-32 dB below the body and the Mini's only pair (n = 1) 30 dB below, so the count
is "several" vs "at most one"; with plastic (dielectric) blades the Mini's pair drops
a further 20 dB and the count is "several" vs "none". The count of pairs is taken
outward from the body, stopping at the first harmonic group whose upper or lower line
is below threshold.
"""

from __future__ import annotations

import numpy as np
import pytest

from microdoppler.radar import Radar
from microdoppler.spectrogram import SpectrogramConfig, spectrogram
from microdoppler.synthesis import (BladeModel, Scaling, Track, add_noise, reference_synthesize, synthesize)

RADAR = Radar(prf_hz=7300.0, carrier_hz=1.35e9)
PRF = RADAR.prf_hz
LAM = RADAR.wavelength_m
V_APPROACH = -5.0
F_BODY = RADAR.doppler_hz(V_APPROACH)  # +45.0 Hz
FULL = SpectrogramConfig(n_bins=0, highpass_hz=0.0)
DETECTION_DB = 13.0
SNR_PER_PULSE_DB = 13.0


def _const(speeds_hz, n):
    return np.broadcast_to(np.asarray(speeds_hz, np.float32), (n, len(speeds_hz)))


def _sim(speeds_hz, *, n=3 * 4096, blade_length_m=0.19, alpha_s=0.0, s_blade=1.0, s_body=1.0, v=V_APPROACH, seed=1,
         **kw):
    track = Track.constant_velocity(500.0, v, n / PRF)
    return synthesize(_const(speeds_hz, n), track, prf_hz=PRF, wavelength_m=LAM, n_blades=2,
                      blade_length_m=blade_length_m, scaling=Scaling(s_body, s_blade, alpha_s), seed=seed, **kw)


def _mean_spectrum(iq):
    spec = spectrogram(iq, PRF, FULL)
    p = 10 * np.log10(np.mean(10 ** (spec.power_db.astype(np.float64) / 10), axis=0))
    return spec.doppler_hz, p


def _wrap(f):
    return (f + PRF / 2) % PRF - PRF / 2


def _peak(f, p, f0, half_bins=1):
    """Peak power [dB] and its frequency within +-half_bins of f0."""
    bin_hz = f[1] - f[0]
    sel = np.abs(_wrap(f - f0)) <= half_bins * bin_hz + 1e-9
    i = np.flatnonzero(sel)[np.argmax(p[sel])]
    return p[i], f[i]


def test_lines_at_body_plus_minus_n_b_fm_for_every_motor():
    speeds = [85.0, 90.0, 95.0, 100.0]
    f, p = _mean_spectrum(_sim(speeds))
    bin_hz = f[1] - f[0]
    floor = np.median(p)
    for fm in speeds:
        for n in (1, 2, 3, 4):
            for sign in (+1, -1):
                f_exp = _wrap(F_BODY + sign * n * 2 * fm)
                # the strongest bin within +-3 bins must be within one bin of the prediction
                sel = np.abs(_wrap(f - f_exp)) <= 3 * bin_hz
                i = np.flatnonzero(sel)[np.argmax(p[sel])]
                assert abs(_wrap(f[i] - f_exp)) <= bin_hz, (fm, n, sign, f[i], f_exp)
                assert p[i] > floor + 40, (fm, n, sign)


def test_four_distinct_lines_per_harmonic_group_and_one_for_equal_speeds():
    from scipy.signal import find_peaks

    for speeds, expected in (([85.0, 90.0, 95.0, 100.0], 4), ([100.0] * 4, 1)):
        f, p = _mean_spectrum(_sim(speeds))
        for n in (1, 2):
            for sign in (+1, -1):
                lo, hi = sorted((F_BODY + sign * n * 2 * 85.0, F_BODY + sign * n * 2 * 100.0))
                sel = (f >= lo - 6) & (f <= hi + 6)
                peaks, _ = find_peaks(p[sel], prominence=10.0, height=np.max(p[sel]) - 20)
                assert len(peaks) == expected, (speeds, n, sign, f[sel][peaks])


@pytest.mark.parametrize("v, sign", [(-5.0, +1), (+5.0, -1)])
def test_body_doppler_sign(v, sign):
    f, p = _mean_spectrum(_sim([85.0, 90.0, 95.0, 100.0], v=v, n=2 * 4096))
    f_peak = f[np.argmax(p)]
    assert np.sign(f_peak) == sign
    assert abs(f_peak - sign * 2 * abs(v) / LAM) <= f[1] - f[0]


def _visible_pairs(iq, speeds):
    f, p = _mean_spectrum(iq)
    floor = np.median(p)
    thr = floor + DETECTION_DB
    body, _ = _peak(f, p, F_BODY)
    count = 0
    for n in range(1, 12):
        up = max(_peak(f, p, F_BODY + n * 2 * fm)[0] for fm in speeds)
        lo = max(_peak(f, p, F_BODY - n * 2 * fm)[0] for fm in speeds)
        if up < thr or lo < thr:
            break
        count += 1
    return count, body - thr


def _noisy(iq, seed):
    return add_noise(iq, 1.0 / 10 ** (SNR_PER_PULSE_DB / 10), seed)


def test_sideband_pairs_fall_as_alpha_grows():
    speeds = [85.0, 90.0, 95.0, 100.0]
    counts = []
    for alpha in (0.0, 1e-3, 5e-3):
        c, body_over_thr = _visible_pairs(_noisy(_sim(speeds, alpha_s=alpha), 7), speeds)
        assert 28 < body_over_thr < 38  # the threshold really sits ~33 dB below the body
        counts.append(c)
    assert counts[0] >= 3, counts
    assert all(a >= b for a, b in zip(counts, counts[1:])), counts
    assert counts[-1] == 0, counts


def test_rotor_harmonics_are_the_bessel_integrals_of_eq1():
    """Eq. (1) integrated along the blade: harmonic n of a B-blade rotor (n = m B) is
    B (-j)^n int_0^L J_n(k s) ds with k = 4 pi / lambda, so its magnitude is set by
    the blade's electrical length k L (sideband count vs blade length and wavelength)."""
    from scipy.integrate import quad
    from scipy.special import jv

    for L, lam in ((0.06, LAM), (0.19, LAM), (0.19, 0.03), (0.12, 0.5)):
        k = 4 * np.pi / lam
        c = np.fft.fft(BladeModel(2, L, lam).table().astype(np.complex128)) / 2 ** 16
        for n in (2, 4, 6):
            expected = 2 * quad(lambda s: jv(n, k * s), 0, L, limit=200)[0]
            assert abs(abs(c[n]) - abs(expected)) < 1e-4 * max(abs(expected), 1e-3), (L, lam, n)
        assert np.max(np.abs(c[1::2])) < 1e-6  # two equal blades: odd harmonics cancel
    # the first pair hardly depends on L once k L > 3: |c_B| ~ (1 - J0(k L)) / k, so the
    # 0.06 m Mini blade's first pair is only ~2 dB below the 0.19 m Inspire blade's
    first = {L: abs(np.fft.fft(BladeModel(2, L, LAM).table().astype(np.complex128))[2]) for L in (0.06, 0.19)}
    assert 1.5 < 20 * np.log10(first[0.19] / first[0.06]) < 3.0, first


def test_sideband_pairs_fall_as_blade_shrinks_thin_wire():
    """Eq. (1) alone: fewer pairs for shorter blades, but the Mini keeps its first pair
    (see the test above), so 'none' needs the dielectric blade model below."""
    speeds = [85.0, 90.0, 95.0, 100.0]
    counts = {L: _visible_pairs(_noisy(_sim(speeds, blade_length_m=L), 8), speeds)[0] for L in (0.19, 0.12, 0.06)}
    assert counts[0.19] >= 3, counts  # Inspire: several pairs
    assert counts[0.19] >= counts[0.12] >= counts[0.06], counts
    assert counts[0.06] <= 1, counts


def test_dielectric_blades_mini_gives_no_pair_where_inspire_gives_several():
    """Same S_blade, speeds, SNR and threshold, only the blade length differs; plastic
    blades (blade_scattering="dielectric"): the 0.06 m Mini blade gives no sideband
    pair at L-band where the 0.19 m Inspire blade gives several."""
    speeds = [85.0, 90.0, 95.0, 100.0]
    counts = {}
    for L in (0.22, 0.19, 0.12, 0.06):
        iq = _noisy(_sim(speeds, blade_length_m=L, blade_scattering="dielectric"), 8)
        counts[L], body_over_thr = _visible_pairs(iq, speeds)
        assert 28 < body_over_thr < 38
    assert counts[0.19] >= 3 and counts[0.22] >= 3, counts  # Inspire, Matrice: several
    assert counts[0.19] >= counts[0.12] >= counts[0.06], counts
    assert counts[0.06] == 0, counts  # Mini: none


def test_dielectric_gain_scales_as_length_over_wavelength_squared():
    from microdoppler.synthesis import DIELECTRIC_REF_LENGTH_M, DIELECTRIC_REF_WAVELENGTH_M, blade_scattering_gain

    assert blade_scattering_gain(0.06, LAM) == 1.0  # thin wire: eq. (1) unchanged
    assert blade_scattering_gain(DIELECTRIC_REF_LENGTH_M, DIELECTRIC_REF_WAVELENGTH_M, "dielectric") == pytest.approx(1)
    g = blade_scattering_gain(0.06, LAM, "dielectric")
    assert g == pytest.approx((0.06 / 0.19) ** 2 * (DIELECTRIC_REF_WAVELENGTH_M / LAM) ** 2)
    assert blade_scattering_gain(0.06, LAM / 2, "dielectric") == pytest.approx(4 * g)  # ~ k^2
    with pytest.raises(ValueError, match="blade_scattering"):
        blade_scattering_gain(0.06, LAM, "metal")
    # in the spectrum: the Mini's first pair drops by 20 log10(g) (-20 dB) against eq. (1)
    speeds = [90.0]
    f, p_wire = _mean_spectrum(_sim(speeds, blade_length_m=0.06, s_body=0.0))
    _, p_diel = _mean_spectrum(_sim(speeds, blade_length_m=0.06, s_body=0.0, blade_scattering="dielectric"))
    for sign in (+1, -1):
        drop = _peak(f, p_wire, F_BODY + sign * 180.0)[0] - _peak(f, p_diel, F_BODY + sign * 180.0)[0]
        assert drop == pytest.approx(-20 * np.log10(g), abs=0.05), (sign, drop)


def test_mini_blade_has_no_pair_with_a_modest_envelope():
    """With the paper's smallest Inspire alpha (5.5e-3 s, Table IV) the Mini shows none."""
    speeds = [85.0, 90.0, 95.0, 100.0]
    assert _visible_pairs(_noisy(_sim(speeds, blade_length_m=0.06, alpha_s=5.5e-3), 9), speeds)[0] == 0


def test_fast_kernel_agrees_with_reference(rng):
    n = 2500
    rev = (rng.uniform(60, 110, (1, 4)) + np.cumsum(rng.normal(0, 0.05, (n, 4)), axis=0)).astype(np.float32)
    track = Track(np.array([0.0, 0.2, 0.4]), np.array([500.0, 499.0, 497.6]))
    kw = dict(prf_hz=PRF, wavelength_m=LAM, n_blades=2, blade_length_m=0.19, scaling=Scaling(1.0, 0.7, 0.0),
              initial_cycles=rng.uniform(0, 1, 4))
    ref = reference_synthesize(rev, track, **kw)
    fast = synthesize(rev, track, **kw)
    err = np.max(np.abs(fast - ref)) / np.max(np.abs(ref))
    assert err < 1e-3, err  # table lookup (2**16 entries) + linear carrier interpolation


def test_rotor_table_matches_eq1():
    bm = BladeModel(2, 0.19, LAM)
    i = np.arange(0, bm.table_size, 997)
    assert np.allclose(bm.table()[i], bm.rotor(2 * np.pi * i / bm.table_size), atol=1e-6)


@pytest.mark.parametrize("alpha", [0.0, 0.01])
def test_chunk_size_independence(rng, alpha):
    n = 20000
    rev = (90 + np.cumsum(rng.normal(0, 0.05, (n, 4)), axis=0)).astype(np.float32)
    track = Track(np.array([0.0, 1.0, 3.0]), np.array([800.0, 795.0, 790.0]))
    kw = dict(prf_hz=PRF, wavelength_m=LAM, n_blades=2, blade_length_m=0.19, scaling=Scaling(1.0, 1.0, alpha),
              seed=3, margin=4096)
    base = synthesize(rev, track, chunk=n, **kw)
    for chunk in (1000, 4099, 8192):
        # alpha = 0 and the (default) harmonic envelope: chunking changes nothing
        np.testing.assert_array_equal(synthesize(rev, track, chunk=chunk, **kw), base)
    if alpha > 0:
        base = synthesize(rev, track, chunk=n, envelope_method="fft", **kw)
        for chunk in (1000, 4099, 8192):
            other = synthesize(rev, track, chunk=chunk, envelope_method="fft", **kw)
            # overlap-save truncates the envelope's Lorentzian impulse response at the margin
            assert np.max(np.abs(other - base)) < 1e-2 * np.max(np.abs(base)), chunk


def _harmonic_vs_fft(rev, alpha, n, n_blades=2):
    track = Track.constant_velocity(500.0, V_APPROACH, n / PRF)
    kw = dict(prf_hz=PRF, wavelength_m=LAM, n_blades=n_blades, blade_length_m=0.19, scaling=Scaling(0.0, 1.0, alpha),
              seed=3)
    h = synthesize(rev, track, envelope_method="harmonic", **kw)
    # one FFT over the record with a long margin: the linear filter without truncation
    f = synthesize(rev, track, envelope_method="fft", chunk=n, margin=16384, **kw)
    s = slice(8192, n - 8192)  # away from the FFT filter's zero-padded record edges
    d, ref = np.abs(h - f)[s], np.abs(f[s])
    return np.max(d) / np.max(ref), np.sqrt(np.mean(d ** 2) / np.mean(ref ** 2))


@pytest.mark.parametrize("alpha, n_blades", [(5.5e-3, 2), (0.02, 2), (5.5e-3, 3)])
def test_harmonic_envelope_equals_fft_filter_for_constant_speeds(rng, alpha, n_blades):
    """At constant speed, harmonic n of the rotor sits at n f_m: the per-harmonic gain
    exp(-alpha |n| f_m) *is* the filter H(f) = exp(-alpha |f|)."""
    n = 4 * 8192
    rev = _const(rng.uniform(60, 110, 4), n)
    err_max, err_rms = _harmonic_vs_fft(rev, alpha, n, n_blades)
    # the residue is the tables' nearest-angle lookup (2048 angles per 1/B turn) and
    # nearest speed row (0.25 rev/s): ~1e-3 of the signal, 60 dB below it
    assert err_rms < 1e-3 and err_max < 2e-3, (err_max, err_rms)


def test_harmonic_envelope_close_to_fft_filter_for_slowly_varying_speeds(rng):
    """Quasi-static envelope: speeds that drift by a few rev/s per second (a flying
    quadcopter) give the same signal as the linear filter to table accuracy."""
    n = 4 * 8192
    t = np.arange(n) / PRF
    rev = (rng.uniform(80, 100, 4) + 5 * np.sin(2 * np.pi * t[:, None] / rng.uniform(2, 4, 4))).astype(np.float32)
    err_max, err_rms = _harmonic_vs_fft(rev, 5.5e-3, n)
    assert err_max < 2e-3 and err_rms < 1e-3, (err_max, err_rms)


def test_harmonic_envelope_scales_each_line_by_exp_minus_alpha_n_fm():
    """One motor at a speed whose lines fall on FFT bins: the blade line at n f_m
    (n = +-2, +-4) is scaled by exp(-alpha |n| f_m) relative to alpha = 0."""
    n, alpha = 8192, 5.5e-3
    fm = 112 * PRF / n  # 99.8 rev/s: harmonic n on bin 112 n
    rev = _const([fm], n)
    track = Track.constant_velocity(500.0, 0.0, n / PRF)
    kw = dict(prf_hz=PRF, wavelength_m=LAM, n_blades=2, blade_length_m=0.19, seed=1)
    x0 = np.fft.fft(synthesize(rev, track, scaling=Scaling(0.0, 1.0, 0.0), **kw).astype(np.complex128))
    xa = np.fft.fft(synthesize(rev, track, scaling=Scaling(0.0, 1.0, alpha), **kw).astype(np.complex128))
    for h in (-4, -2, 2, 4):
        ratio = abs(xa[(112 * h) % n]) / abs(x0[(112 * h) % n])
        assert np.isclose(ratio, np.exp(-alpha * abs(h) * fm), rtol=5e-3), (h, ratio)
    assert np.isclose(abs(xa[0]), abs(x0[0]), rtol=1e-3)  # the DC term (n = 0) is not attenuated


def test_envelope_method_validation():
    with pytest.raises(ValueError, match="envelope_method"):
        _sim([90.0], n=1000, alpha_s=1e-3, envelope_method="fir")
    with pytest.raises(ValueError, match="harmonic"):
        _sim([90.0], n=1000, alpha_s=1e-3, envelope_method="harmonic", envelope=lambda f: np.ones_like(f))


def test_energy_parseval():
    """Mean power = |S_body|^2 + 2 Re(S_body S_blade <m>) + S_blade^2 <|m|^2>; no filter -> exact
    decomposition; with alpha the blade power falls by the envelope's weighted mean."""
    speeds = [85.0, 90.0, 95.0, 100.0]
    n = 4 * 4096
    blade_only = _sim(speeds, n=n, seed=2) - _sim(speeds, n=n, seed=2, s_blade=0.0)
    x = _sim(speeds, n=n, seed=2)
    X = np.fft.fft(x.astype(np.complex128))
    assert np.isclose(np.sum(np.abs(x.astype(np.complex128)) ** 2), np.sum(np.abs(X) ** 2) / n, rtol=1e-6)
    # the blade power equals the sum of the rotor-table harmonic powers (each motor separately)
    G = BladeModel(2, 0.19, LAM).rotor(2 * np.pi * np.arange(4096) / 4096)
    per_motor = np.mean(np.abs(G) ** 2)
    mean_dc = np.mean(G)
    expected = 4 * (per_motor - abs(mean_dc) ** 2) + abs(4 * mean_dc) ** 2
    assert np.isclose(np.mean(np.abs(blade_only) ** 2), expected, rtol=0.05)
    filtered = _sim(speeds, n=n, seed=2, alpha_s=0.01) - _sim(speeds, n=n, seed=2, alpha_s=0.01, s_blade=0.0)
    assert np.mean(np.abs(filtered) ** 2) < 0.6 * np.mean(np.abs(blade_only) ** 2)


def test_blade_phase_is_integral_of_speed():
    """A linear speed ramp f(t) = f0 + k t gives a line at 2 f(t) (B = 2) at every time:
    the instantaneous frequency of a phase that integrates the speed. Omega t would
    put the line at 2 (f0 + 2 k t)."""
    f0, k = 60.0, 20.0  # rev/s, rev/s^2
    n = 6 * 4096
    t = np.arange(n) / PRF
    rev = np.repeat((f0 + k * t)[:, None].astype(np.float32), 1, axis=1)
    track = Track.constant_velocity(500.0, 0.0, n / PRF)
    iq = synthesize(rev, track, prf_hz=PRF, wavelength_m=LAM, n_blades=2, blade_length_m=0.19,
                    scaling=Scaling(0.0, 1.0, 0.0), seed=4)
    spec = spectrogram(iq, PRF, SpectrogramConfig(n_bins=0, highpass_hz=0.0))
    f = spec.doppler_hz
    for j, tc in enumerate(spec.time_s):
        right = 2 * (f0 + k * tc)  # first sideband, integral of the speed
        wrong = 2 * (f0 + 2 * k * tc)  # Omega_t * t
        sel = (f > 80) & (f < 2 * (f0 + 2 * k * t[-1]) + 20)
        fpk = f[sel][np.argmax(spec.power_db[j, sel])]
        assert abs(fpk - right) <= 2 * spec.bin_hz, (tc, fpk, right)
        if tc > 0.5:
            assert abs(fpk - wrong) > 5 * spec.bin_hz


def test_same_seed_same_output_and_seed_changes_phases():
    a = _sim([85.0, 90.0], n=3000, seed=5)
    b = _sim([85.0, 90.0], n=3000, seed=5)
    c = _sim([85.0, 90.0], n=3000, seed=6)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)


def test_zarr_input_is_sliced_not_loaded(tmp_path):
    import zarr

    n = 10000
    rev = np.tile(np.array([85, 90, 95, 100], np.float32), (n, 1))
    z = zarr.create_array(str(tmp_path / "r.zarr"), shape=rev.shape, dtype=np.float32, chunks=(4096, 4))
    z[...] = rev
    track = Track.constant_velocity(500.0, -5.0, n / PRF)
    kw = dict(prf_hz=PRF, wavelength_m=LAM, n_blades=2, blade_length_m=0.19, seed=1, chunk=3000)
    np.testing.assert_array_equal(synthesize(z, track, **kw), synthesize(rev, track, **kw))


def test_envelope_callable_and_hooks():
    """An envelope that removes negative frequencies (relative to the body) removes the
    lower sidebands only; hooks see every pulse once, in order."""
    speeds = [90.0]
    seen = []

    def body_hook(i0, i1, t, x):
        seen.append((i0, i1))
        assert len(t) == i1 - i0 == len(x) and np.isclose(t[0], i0 / PRF)

    iq = _sim(speeds, n=3 * 4096, envelope=lambda f: (f >= 0).astype(np.float64), body_hook=body_hook,
              chunk=5000, margin=2048)
    assert seen == [(0, 5000), (5000, 10000), (10000, 12288)]
    f, p = _mean_spectrum(iq)
    up, _ = _peak(f, p, F_BODY + 2 * 90.0)
    lo, _ = _peak(f, p, F_BODY - 2 * 90.0)
    assert up - lo > 30, (up, lo)
