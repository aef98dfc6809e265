"""The one windowed periodogram kernel (:mod:`microdoppler.spectra.periodogram`): against
a direct numpy computation, against physics (a tone's coherent gain, white noise's
mean power), the spectrogram on it against scipy's ShortTimeFFT, and no second
periodogram chain outside ``spectra/``."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.signal import ShortTimeFFT
from scipy.signal.windows import blackmanharris, hann

from microdoppler.codeversion import PACKAGE_DIR
from microdoppler.spectra import periodogram, spectrogram, stft, window
from microdoppler.spectra.periodogram import cpi_starts
from microdoppler.spectra.spectrogram import SpectrogramConfig, cpi_grid, highpass


def _series(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return (rng.standard_normal(n) + 1j * rng.standard_normal(n)) + 3.0 - 1.0j


def test_window_is_the_periodic_window():
    assert np.array_equal(window(4096), blackmanharris(4096, sym=False))
    assert np.array_equal(window(1000, "hann"), hann(1000, sym=False))
    w = window(64)
    w[:] = 0.0  # a copy: the cached window is untouched
    assert window(64).max() == 1.0


def test_cpi_starts():
    assert cpi_starts(10, 4, 2).tolist() == [0, 2, 4, 6]
    assert cpi_starts(11, 4, 3).tolist() == [0, 3, 6]
    assert cpi_starts(3, 4, 2).tolist() == []


@pytest.mark.parametrize("n_fft, hop", [(256, 128), (100, 37), (64, 64)])
def test_periodogram_is_the_direct_computation(n_fft, hop):
    """Each CPI by hand: slice, remove the mean, window, FFT, shift, |.|^2, scale, average."""
    x = _series(2000)
    w = blackmanharris(n_fft, sym=False)
    starts = range(0, len(x) - n_fft + 1, hop)
    ref = []
    for s in starts:
        seg = x[s : s + n_fft]
        seg = seg - seg.mean()
        ref.append(np.abs(np.fft.fftshift(np.fft.fft(seg * w))) ** 2 / np.sum(w**2))
    ref = np.array(ref)
    got = periodogram(x, n_fft, hop=hop, demean=True, shift=True, scale=True)
    assert got.shape == (len(starts), n_fft)
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12 * ref.max())
    bins = np.array([0, 5, n_fft // 2, n_fft - 1])
    np.testing.assert_allclose(
        periodogram(x, n_fft, hop=hop, demean=True, shift=True, scale=True, bins=bins), ref[:, bins], rtol=1e-12
    )
    np.testing.assert_allclose(
        periodogram(x, n_fft, hop=hop, demean=True, shift=True, scale=True, average=True), ref.mean(0), rtol=1e-12
    )
    # without the options: the raw power of the windowed FFT, in FFT order
    raw = np.array([np.abs(np.fft.fft(x[s : s + n_fft] * w)) ** 2 for s in starts])
    np.testing.assert_allclose(periodogram(x, n_fft, hop=hop), raw, rtol=1e-12, atol=1e-12 * raw.max())
    # the complex transform of given CPIs
    X = stft(x, n_fft, starts=np.array([7, 300]))
    np.testing.assert_allclose(X[1], np.fft.fft(x[300 : 300 + n_fft] * w), rtol=1e-12, atol=1e-9)


def test_single_precision_keeps_complex64():
    x = _series(4096).astype(np.complex64)
    X = stft(x, 1024, window=window(1024).astype(np.float32), dtype=np.complex64)
    assert X.dtype == np.complex64
    ref = stft(x, 1024)
    assert np.max(np.abs(X - ref)) < 1e-5 * np.max(np.abs(ref))


def test_tone_lands_in_its_bin_with_the_coherent_gain():
    """A tone of amplitude A on bin k's centre reads A^2 sum(w)^2 in bin k (and, shifted,
    in bin k + n/2); scaled by the window's energy, A^2 sum(w)^2 / sum(w^2)."""
    n, k, amp = 512, 37, 2.5
    x = amp * np.exp(2j * np.pi * k * np.arange(3 * n) / n)
    w = blackmanharris(n, sym=False)
    p = periodogram(x, n)
    assert (p.argmax(axis=1) == k).all()
    np.testing.assert_allclose(p[:, k], amp**2 * w.sum() ** 2, rtol=1e-12)
    # Blackman-Harris's sidelobes: nothing 5 bins away above -92 dB of the line
    far = np.abs((np.arange(n) - k + n // 2) % n - n // 2) >= 5
    assert p[:, far].max() < 10 ** (-92 / 10) * p[:, k].max()
    ps = periodogram(x, n, shift=True, scale=True)
    assert (ps.argmax(axis=1) == k + n // 2).all()
    np.testing.assert_allclose(ps[:, k + n // 2], amp**2 * w.sum() ** 2 / np.sum(w**2), rtol=1e-12)


def test_white_noise_mean_power_is_its_variance_times_the_window_energy():
    """Complex white noise of variance sigma^2 per pulse: E|X_k|^2 = sigma^2 sum(w^2) in
    every bin, so the energy-scaled periodogram averages to sigma^2. Over 400 disjoint
    CPIs of 1024 bins the mean's relative standard error is about 1/sqrt(409600) times
    sqrt(kappa) (the window correlates neighbouring bins, kappa ~ 2.8): ~0.3 %; 2 % is
    over six of them."""
    n, sigma2 = 1024, 3.0
    rng = np.random.default_rng(1)
    x = np.sqrt(sigma2 / 2) * (rng.standard_normal(400 * n) + 1j * rng.standard_normal(400 * n))
    w = blackmanharris(n, sym=False)
    raw = periodogram(x, n, hop=n)
    assert raw.shape == (400, n)
    assert raw.mean() == pytest.approx(sigma2 * np.sum(w**2), rel=0.02)
    scaled = periodogram(x, n, hop=n, scale=True, average=True)
    assert scaled.shape == (n,)
    assert scaled.mean() == pytest.approx(sigma2, rel=0.02)
    # and no bin stands out: the per-bin means over 400 CPIs scatter by ~5 %
    assert np.abs(scaled / sigma2 - 1).max() < 0.3


def test_bad_input_raises():
    with pytest.raises(ValueError, match="fewer than n_fft"):
        periodogram(np.ones(10, complex), 16)
    with pytest.raises(ValueError, match="1-D"):
        periodogram(np.ones((2, 64), complex), 16)
    with pytest.raises(ValueError, match="window has shape"):
        periodogram(np.ones(64, complex), 16, window=np.ones(8))


@pytest.mark.parametrize(
    "n_fft, overlap, n_bins, n_pulses", [(4096, 0.5, 480, 20000), (1000, 0.3, 0, 7777), (512, 0.75, 33, 3000)]
)
def test_spectrogram_on_the_kernel_equals_scipy_short_time_fft(n_fft, overlap, n_bins, n_pulses):
    """The spectrogram runs on the kernel; its CPIs, times, Doppler axis and power are
    scipy's ShortTimeFFT's (centred, windows wholly inside the record) to the bit."""
    prf = 7300.0
    cfg = SpectrogramConfig(n_fft=n_fft, overlap=overlap, n_bins=n_bins)
    iq = _series(n_pulses, seed=2).astype(np.complex64)
    spec = spectrogram(iq, prf, cfg)
    sft = ShortTimeFFT(blackmanharris(n_fft, sym=False), hop=cfg.hop, fs=prf, fft_mode="centered", scale_to=None)
    x = highpass(iq, prf, cfg.highpass_hz, cfg.highpass_order)
    k0, k1 = sft.lower_border_end[1], sft.upper_border_begin(len(x))[1]
    S = sft.stft(x, p0=k0, p1=k1)
    f = sft.f
    if n_bins:
        lo = n_fft // 2 - n_bins // 2
        S, f = S[lo : lo + n_bins], f[lo : lo + n_bins]
    ref = 10 * np.log10((S.real**2 + S.imag**2).T + 1e-30).astype(np.float32)  # as the spectrogram always did
    assert np.array_equal(spec.power_db, ref)
    assert np.array_equal(spec.time_s, sft.t(len(x), p0=k0, p1=k1))
    assert np.array_equal(spec.doppler_hz, f)
    starts, _, _ = cpi_grid(len(x), prf, cfg)
    assert np.array_equal(starts, np.arange(k0, k1) * cfg.hop - sft.m_num_mid)


#: modules outside spectra/ that may name an analysis window, each with its reason
WINDOW_ALLOWED = {
    # the docs' independent recording generator: it must not share the code it checks
    "examples.py",
    # a Hann window across fast time (the FMCW range FFT), not a Doppler periodogram
    "importing/fmcw.py",
}


def test_no_periodogram_window_outside_spectra():
    """Only spectra/ builds an analysis window (scipy's blackmanharris or get_window):
    everything else takes :func:`microdoppler.spectra.window` or calls the kernel."""
    pattern = re.compile(r"\b(blackmanharris|get_window)\b")
    found = set()
    for path in PACKAGE_DIR.rglob("*.py"):
        rel = path.relative_to(PACKAGE_DIR).as_posix()
        if rel.startswith("spectra/"):
            continue
        code = [line.split("#")[0] for line in path.read_text().splitlines()]
        if any(pattern.search(line) for line in code):
            found.add(rel)
    assert found - WINDOW_ALLOWED == set(), "build the window with microdoppler.spectra.window"
    assert WINDOW_ALLOWED - found == set(), "an allowed module no longer names a window: drop it from the list"
