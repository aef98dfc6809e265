"""Raw FMCW data -> the target's slow-time I/Q and track (``microdoppler import``).

An FMCW radar records, per chirp, ``n_samples`` fast-time samples of the beat signal
(the received sweep mixed with the transmitted one), in a cube
``[n_chirps, n_samples]`` or ``[n_chirps, n_samples, n_channels]``, real (a real
mixer) or complex (an I/Q mixer). This module turns it into what flight-zarr/1
holds: one range cell's slow-time I/Q at the chirp rate and the target's track
(the cube and its parameters are read by :mod:`microdoppler.io.fmcw_files`).

Conventions
-----------
- ``bandwidth_hz`` is the frequency swept over the ``n_samples`` sampled points of a
  chirp (the ramp slope is ``bandwidth_hz * sample_rate_hz / n_samples`` [Hz/s]), so
  range bin ``k`` of an ``nfft``-point FFT lies at
  ``R = k * c / (2 * bandwidth_hz) * n_samples / nfft`` [m].
- ``carrier_hz`` is the sweep's centre frequency: the slow-time phase of a range bin
  is referred to the middle of the sampled ramp (see :func:`range_profiles`), so
  the Doppler scale is ``2 v / lambda`` at the centre.
- The beat of a scatterer at range R is at ``+2 R slope / c`` with phase
  ``+4 pi R / lambda`` (the transmitted sweep times the conjugate of the received
  one, as a real mixer's positive-frequency half gives): ``beat_sign="positive"``.
  An I/Q mixer that forms received times conjugate transmitted puts targets at
  negative beat frequencies: ``beat_sign="negative"``. Either way the slow-time
  I/Q written follows flight-zarr's sign (phase ``-4 pi R / lambda``: an approaching
  target at positive Doppler).

Steps (:func:`process_fmcw`)
----------------------------
1. Range profiles (:func:`range_profiles`): per chirp, the mean removed, a Hann
   window and an FFT over fast time; the positive-frequency half (bins
   ``0 .. nfft/2 - 1``) is kept, for real and complex input alike.
2. Moving-target power (:func:`moving_power`): per CPI (a block of ``cpi_chirps``
   chirps) and range bin, the power left after removing the bin's mean over the CPI
   (its static, zero-Doppler part), summed over chirps and channels.
3. The target's bin per CPI (:func:`track_range_bins`): the path through the CPIs
   that maximises the summed moving-target power over the CPI's median bin [dB],
   moving at most ``max_step_bins`` bins from one CPI to the next; or one fixed bin.
4. Range per CPI (:func:`sub_bin_position`): the bin, refined within +-0.5 bin by a
   parabola through the log moving power of the bin and its neighbours.
5. Slow time (:func:`bin_slow_time`): each chirp's value at the target's range
   (single-bin DFTs of the same window, interpolated linearly between the two bins
   around the smoothed range, so the cell glides with the target), channels
   phase-aligned to the first and averaged (weights from the target's moving part,
   smoothed over 5 CPIs and interpolated per chirp), conjugated to flight-zarr's
   sign. Stationary clutter is left in. With ``range_bin`` fixed: that bin.
6. Track: one row per CPI at its centre time, the range of step 4; radial velocity
   (:func:`radial_velocity`) from a local straight-line fit of the
   range over ~0.5 s, replaced by the body Doppler (the strongest non-static line of
   the CPI's slow time, found on a zero-padded Hann spectrum and refined by a
   parabola through its log power, ``v = -f lambda / 2``, unfolded to the alias
   nearest the range rate) where the two agree within the range rate's uncertainty.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..io.fmcw_files import cube_array
from ..io.recordings import BEAT_SIGNS

SPEED_OF_LIGHT_MPS = 299_792_458.0
#: what must be known to form range profiles
FMCW_REQUIRED = ("chirp_rate_hz", "bandwidth_hz", "sample_rate_hz", "carrier_hz")
#: the CPI defaults to the largest power of two of chirps within this time [s] (at least 16 chirps)
DEFAULT_CPI_S = 0.05
#: the range rate is a straight-line fit over this time [s] (at least 5 CPIs)
VELOCITY_FIT_S = 0.5


@dataclass(frozen=True)
class FmcwParameters:
    """An FMCW radar's chirp parameters.

    Attributes
    ----------
    chirp_rate_hz : float
        Chirps per second: the slow-time sample rate, the store's ``prf_hz`` [Hz].
    bandwidth_hz : float
        Frequency swept over the ``n_samples`` sampled points of a chirp [Hz].
    sample_rate_hz : float
        Fast-time (ADC) sample rate [Hz].
    carrier_hz : float
        Centre frequency of the sampled sweep [Hz].
    n_samples : int
        Fast-time samples per chirp.
    nfft : int
        Range FFT length (>= ``n_samples``; zero-padded).
    """

    chirp_rate_hz: float
    bandwidth_hz: float
    sample_rate_hz: float
    carrier_hz: float
    n_samples: int
    nfft: int = 0

    def __post_init__(self):
        for name in ("chirp_rate_hz", "bandwidth_hz", "sample_rate_hz", "carrier_hz"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name}={v} must be a finite number > 0")
        if self.n_samples < 8:
            raise ValueError(f"n_samples={self.n_samples} must be >= 8")
        if self.nfft == 0:
            object.__setattr__(self, "nfft", int(self.n_samples))
        if self.nfft < self.n_samples:
            raise ValueError(f"nfft={self.nfft} must be >= n_samples={self.n_samples}")

    @property
    def wavelength_m(self) -> float:
        return SPEED_OF_LIGHT_MPS / self.carrier_hz

    @property
    def sampled_chirp_s(self) -> float:
        """Duration of a chirp's sampled part [s]."""
        return self.n_samples / self.sample_rate_hz

    @property
    def slope_hz_per_s(self) -> float:
        return self.bandwidth_hz / self.sampled_chirp_s

    @property
    def range_bin_m(self) -> float:
        """Range per FFT bin [m]: c / (2 B) * n_samples / nfft."""
        return SPEED_OF_LIGHT_MPS / (2 * self.bandwidth_hz) * self.n_samples / self.nfft

    @property
    def n_bins(self) -> int:
        """Range bins kept (the positive-frequency half)."""
        return self.nfft // 2

    @property
    def max_range_m(self) -> float:
        return self.n_bins * self.range_bin_m


def default_cpi_chirps(chirp_rate_hz: float) -> int:
    """The largest power of two of chirps within :data:`DEFAULT_CPI_S` (>= 16)."""
    return max(16, 2 ** int(math.floor(math.log2(max(chirp_rate_hz * DEFAULT_CPI_S, 1.0)))))


def check_timing(params: FmcwParameters, source) -> None:
    """The sampled part of a chirp must fit in the chirp period."""
    period = 1 / params.chirp_rate_hz
    if params.sampled_chirp_s > period * (1 + 1e-9):
        raise InputError(
            source,
            "sample_rate_hz",
            f"is {params.sample_rate_hz:g} Hz: {params.n_samples} samples "
            f"take {params.sampled_chirp_s * 1e6:.1f} us, longer than the chirp period "
            f"1/chirp_rate_hz = {period * 1e6:.1f} us",
            "n_samples / sample_rate_hz <= 1 / chirp_rate_hz (check the chirp rate and sample rate)",
        )


# ---- processing -----------------------------------------------------------------------


def _window(params: FmcwParameters) -> np.ndarray:
    from scipy.signal import get_window

    return get_window("hann", params.n_samples, fftbins=False)


def _centre_ref(params: FmcwParameters, k) -> np.ndarray:
    """``exp(+j 2 pi k n_c / nfft)`` with ``n_c = (n_samples - 1) / 2``: refers a bin's
    phase to the middle of the sampled ramp, so it does not jump when the target's
    peak moves from one bin to the next."""
    n_c = (params.n_samples - 1) / 2
    return np.exp(2j * np.pi * np.asarray(k, np.float64) * n_c / params.nfft)


def range_profiles(block: np.ndarray, params: FmcwParameters, *, beat_sign: str = "positive") -> np.ndarray:
    """Range profiles of a block of chirps.

    Parameters
    ----------
    block : ndarray, real or complex [n_chirps, n_samples, n_channels]
        Beat samples.
    params : FmcwParameters
    beat_sign : {"positive", "negative"}
        Where targets lie in beat frequency (see the module docstring).

    Returns
    -------
    ndarray, complex128 [n_chirps, n_bins, n_channels]
        Bins ``0 .. nfft/2 - 1`` (range ``k * range_bin_m``), each with its phase
        referred to the middle of the ramp and, for ``beat_sign="negative"``,
        conjugated, so a scatterer at range R has phase ``+4 pi R / lambda`` either way.
    """
    x = block - block.mean(axis=1, keepdims=True)
    x = x * _window(params)[None, :, None]
    X = np.fft.fft(x, n=params.nfft, axis=1)
    nb = params.n_bins
    if beat_sign == "negative":
        k = -np.arange(nb)
        return np.conj(X[:, k % params.nfft, :] * _centre_ref(params, k)[None, :, None])
    k = np.arange(nb)
    return X[:, :nb, :] * _centre_ref(params, k)[None, :, None]


def cpi_blocks(n_chirps: int, cpi_chirps: int) -> list[slice]:
    """Consecutive CPIs of ``cpi_chirps`` chirps; the last may be shorter (>= half a CPI,
    else it joins the one before)."""
    edges = list(range(0, n_chirps, cpi_chirps)) + [n_chirps]
    if len(edges) > 2 and edges[-1] - edges[-2] < cpi_chirps // 2:
        del edges[-2]
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:])]


def moving_power(
    cube: np.ndarray, params: FmcwParameters, cpi_chirps: int, *, beat_sign: str = "positive"
) -> np.ndarray:
    """Moving-target power per CPI and range bin.

    Parameters
    ----------
    cube : ndarray [n_chirps, n_samples, n_channels]
    cpi_chirps : int
        Chirps per CPI (see :func:`cpi_blocks`).

    Returns
    -------
    ndarray, float64 [n_cpi, n_bins]
        Per CPI: the power of each bin's range profile after removing its mean over
        the CPI (the static, zero-Doppler part), summed over chirps and channels.
    """
    out = []
    for sl in cpi_blocks(cube.shape[0], cpi_chirps):
        P = range_profiles(cube[sl], params, beat_sign=beat_sign)
        P = P - P.mean(axis=0, keepdims=True)
        out.append(np.sum(np.abs(P) ** 2, axis=(0, 2)))
    return np.array(out)


def track_range_bins(power: np.ndarray, *, max_step_bins: int = 2, min_bin: int = 1) -> np.ndarray:
    """The target's range bin per CPI: the path of most moving-target power.

    Parameters
    ----------
    power : ndarray, float [n_cpi, n_bins]
        Moving-target power (:func:`moving_power`).
    max_step_bins : int
        Largest move between consecutive CPIs [bins].
    min_bin : int
        Bins below this (0: the DC bin) are never chosen.

    Returns
    -------
    ndarray, int [n_cpi]
        The bins that maximise the sum over CPIs of ``10 log10(P / median_bin P)``
        (dynamic programming), with ``|bin[i+1] - bin[i]| <= max_step_bins``.
    """
    n_cpi, n_bins = power.shape
    med = np.median(power[:, min_bin:], axis=1, keepdims=True)
    tiny = np.finfo(np.float64).tiny
    score = 10 * np.log10(np.maximum(power, tiny) / np.maximum(med, tiny))
    score[:, :min_bin] = -np.inf
    best = score[0].copy()
    back = np.zeros((n_cpi, n_bins), np.int64)
    idx = np.arange(n_bins)
    for i in range(1, n_cpi):
        cand = np.full((2 * max_step_bins + 1, n_bins), -np.inf)
        for j, d in enumerate(range(-max_step_bins, max_step_bins + 1)):
            src = idx + d
            ok = (src >= 0) & (src < n_bins)
            cand[j, ok] = best[src[ok]]
        j = np.argmax(cand, axis=0)
        back[i] = idx + j - max_step_bins
        best = cand[j, idx] + score[i]
    bins = np.empty(n_cpi, np.int64)
    bins[-1] = int(np.argmax(best))
    for i in range(n_cpi - 1, 0, -1):
        bins[i - 1] = back[i, bins[i]]
    return bins


def sub_bin_position(bins: np.ndarray, power: np.ndarray) -> np.ndarray:
    """The target's range per CPI in (fractional) bins.

    Parameters
    ----------
    bins : ndarray, int [n_cpi]
    power : ndarray, float [n_cpi, n_bins]
        Moving-target power.

    Returns
    -------
    ndarray, float [n_cpi]
        ``bin + d`` with ``d`` in [-0.5, 0.5] the vertex of the parabola through the
        log power of the bin and its two neighbours (0 at the edges or without a peak).
    """
    n_bins = power.shape[1]
    frac = np.zeros(len(bins))
    tiny = np.finfo(np.float64).tiny
    for i, k in enumerate(bins):
        if 1 <= k < n_bins - 1:
            lm, l0, lp = np.log(np.maximum(power[i, k - 1 : k + 2], tiny))
            den = lm - 2 * l0 + lp
            if den < 0:
                frac[i] = float(np.clip(0.5 * (lm - lp) / den, -0.5, 0.5))
    return bins + frac


def _local_fit(t: np.ndarray, r: np.ndarray, half: int) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares straight line of ``r(t)`` over ``+-half`` points around each point
    (fewer at the ends): its value and slope there."""
    val, slope = np.empty(len(t)), np.empty(len(t))
    for i in range(len(t)):
        a, b = max(0, i - half), min(len(t), i + half + 1)
        tt = t[a:b] - t[a:b].mean()
        den = float(np.dot(tt, tt))
        slope[i] = float(np.dot(tt, r[a:b] - r[a:b].mean())) / den if den > 0 else 0.0
        val[i] = r[a:b].mean() + slope[i] * (t[i] - t[a:b].mean())
    return val, slope


def _fit_half(params: FmcwParameters, cpi_chirps: int) -> int:
    return max(2, int(round(VELOCITY_FIT_S / (cpi_chirps / params.chirp_rate_hz) / 2)))


def bin_slow_time(
    cube: np.ndarray,
    params: FmcwParameters,
    bins: np.ndarray,
    cpi_chirps: int,
    *,
    beat_sign: str = "positive",
    position: np.ndarray | None = None,
    weights: np.ndarray | None = None,
    smooth_cpis: int = 2,
) -> tuple[np.ndarray, np.ndarray]:
    """The slow-time I/Q of the target's range cell, CPI by CPI.

    Parameters
    ----------
    cube : ndarray [n_chirps, n_samples, n_channels]
    bins : ndarray, int [n_cpi]
        The range bin of each CPI.
    position : ndarray, float [n_chirps], optional
        The target's range in fractional bins at each chirp (smooth). Given, each
        chirp is the linear interpolation between the two bins around it (within
        ``bins[i] +- 1``), so the cell glides with the target instead of jumping a
        bin at a CPI boundary (a jump would put a step into the clutter and the
        body's amplitude, smearing their lines over the spectrum). None: the bin.
    weights : ndarray, complex [n_chirps, n_channels], optional
        Channel weights per chirp; default: ``exp(-j arg C_c) / n_channels`` with
        ``C_c`` the cross-product ``sum_t x_c x_0*`` of the bin's moving part (its
        mean over the CPI removed), summed over ``+-smooth_cpis`` CPIs and
        interpolated between CPI centres: the channels phase-aligned to the first,
        smoothly, so the weights put no steps into the clutter either.

    Returns
    -------
    iq : ndarray, complex64 [n_chirps]
        Flight-zarr's sign (phase ``-4 pi R / lambda``), stationary clutter left in.
    weights : ndarray, complex128 [n_chirps, n_channels]
        The weights used (to apply the same to a background recording).

    Notes
    -----
    A bin is a single-bin DFT of the window of :func:`range_profiles`, its phase
    referred to the middle of the ramp, so neighbouring bins carry a target with the
    same phase and may be interpolated.
    """
    win = _window(params)
    n = np.arange(params.n_samples)
    blocks = cpi_blocks(cube.shape[0], cpi_chirps)
    n_ch = cube.shape[2]
    sgn = -1.0 if beat_sign == "negative" else 1.0
    top = params.n_bins - 1
    cells, cross = [], np.zeros((len(blocks), n_ch), np.complex128)
    for i, sl in enumerate(blocks):
        k = int(bins[i])
        ks = np.arange(max(k - 1, 0), min(k + 1, top) + 1)
        kern = win[:, None] * np.exp(-2j * np.pi * sgn * np.outer(n, ks) / params.nfft)  # single-bin DFTs
        x = cube[sl] - cube[sl].mean(axis=1, keepdims=True)
        y = np.einsum("msc,sb->mbc", x, kern) * _centre_ref(params, sgn * ks)[None, :, None]
        if beat_sign == "negative":
            y = np.conj(y)
        at = int(np.flatnonzero(ks == k)[0])
        mv = y[:, at] - y[:, at].mean(axis=0, keepdims=True)
        cross[i] = np.sum(mv * np.conj(mv[:, :1]), axis=0)
        cells.append((sl, ks, at, y))
    if weights is None:
        cs = np.array([cross[max(0, i - smooth_cpis) : i + smooth_cpis + 1].sum(axis=0) for i in range(len(blocks))])
        tc = np.array([(sl.start + sl.stop - 1) / 2 for sl in blocks])
        tm = np.arange(cube.shape[0])
        weights = np.empty((cube.shape[0], n_ch), np.complex128)
        for c in range(n_ch):
            z = np.interp(tm, tc, cs[:, c].real) + 1j * np.interp(tm, tc, cs[:, c].imag)
            weights[:, c] = np.where(np.abs(z) > 0, np.exp(-1j * np.angle(z)), 1.0) / n_ch
    out = np.empty(cube.shape[0], np.complex128)
    for sl, ks, at, y in cells:
        yc = np.einsum("mbc,mc->mb", y, weights[sl])
        if position is None:
            out[sl] = yc[:, at]
            continue
        pos = np.clip(position[sl], ks[0], ks[-1])
        lo = np.minimum(np.floor(pos).astype(int), ks[-1] - 1) if len(ks) > 1 else np.full(len(pos), ks[0])
        a = pos - lo
        j = lo - ks[0]
        rows = np.arange(len(pos))
        out[sl] = (1 - a) * yc[rows, j] + a * yc[rows, np.minimum(j + 1, len(ks) - 1)]
    return np.conj(out).astype(np.complex64), weights


def radial_velocity(
    t_s: np.ndarray, range_m: np.ndarray, iq: np.ndarray, params: FmcwParameters, cpi_chirps: int
) -> tuple[np.ndarray, np.ndarray]:
    """Radial velocity per CPI [m/s] and whether it came from the body Doppler.

    Parameters
    ----------
    t_s, range_m : ndarray, float [n_cpi]
        CPI centre times [s] and ranges [m].
    iq : ndarray, complex [n_chirps]
        The slow time, flight-zarr's sign.

    Returns
    -------
    v : ndarray, float [n_cpi]
        The range rate (a local straight-line fit over ~:data:`VELOCITY_FIT_S`),
        replaced by ``-f lambda / 2`` of the CPI's strongest non-static line (a
        zero-padded Hann spectrum, the peak refined by a parabola through its log
        power, unfolded to the alias nearest the range rate) where the two agree
        within the range rate's uncertainty (two range bins over the fit's span, at
        least 3 Doppler bins of a CPI).
    from_doppler : ndarray, bool [n_cpi]
    """
    prf, lam = params.chirp_rate_hz, params.wavelength_m
    half = _fit_half(params, cpi_chirps)
    _, v_rng = _local_fit(t_s, range_m, half)
    cpi_s = cpi_chirps / prf
    tol = max(2 * params.range_bin_m / (2 * half * cpi_s), 3 * prf / cpi_chirps * lam / 2)
    v = v_rng.copy()
    from_dop = np.zeros(len(t_s), bool)
    nfft = max(1024, 4 * cpi_chirps)
    tiny = np.finfo(np.float64).tiny
    for i, sl in enumerate(cpi_blocks(len(iq), cpi_chirps)):
        x = iq[sl].astype(np.complex128)
        x = (x - x.mean()) * np.hanning(len(x))
        spec = np.abs(np.fft.fft(x, nfft)) ** 2
        spec[0] = 0.0
        j = int(np.argmax(spec))
        lm, l0, lp = np.log(np.maximum(spec[[j - 1, j, (j + 1) % nfft]], tiny))
        den = lm - 2 * l0 + lp
        f = (j + (float(np.clip(0.5 * (lm - lp) / den, -0.5, 0.5)) if den < 0 else 0.0)) * prf / nfft
        f = (f + prf / 2) % prf - prf / 2
        f_rng = -2 * v_rng[i] / lam
        f = f + prf * np.round((f_rng - f) / prf)  # the alias nearest the range rate
        vd = -f * lam / 2
        if abs(vd - v_rng[i]) <= tol:
            v[i], from_dop[i] = vd, True
    return v, from_dop


@dataclass
class FmcwResult:
    """What :func:`process_fmcw` returns.

    Attributes
    ----------
    iq : ndarray, complex64 [n_chirps]
        The target's slow time (flight-zarr's sign).
    track : dict
        ``time_s`` (CPI centres [s]), ``range_m`` [m], ``radial_velocity_mps`` [m/s],
        ``range_bin`` (int [n_cpi]), ``velocity_from_doppler`` (bool [n_cpi]).
    bins : ndarray, int [n_cpi]
    position : ndarray, float [n_chirps] or None
        The cell's position in fractional bins per chirp (None for a fixed bin).
    weights : ndarray, complex [n_chirps, n_channels]
    power : ndarray, float [n_cpi, n_bins]
    info : dict
        JSON-able summary for the store's ``import`` attribute.
    """

    iq: np.ndarray
    track: dict
    bins: np.ndarray
    position: np.ndarray | None
    weights: np.ndarray
    power: np.ndarray
    info: dict = field(default_factory=dict)


def process_fmcw(
    cube: np.ndarray,
    params: FmcwParameters,
    *,
    cpi_chirps: int | None = None,
    range_bin: int | None = None,
    max_step_bins: int = 2,
    beat_sign: str = "positive",
    source="cube",
) -> FmcwResult:
    """An FMCW cube -> the target's slow-time I/Q and track (the module's steps 1-6).

    Parameters
    ----------
    cube : ndarray, real or complex [n_chirps, n_samples(, n_channels)]
    params : FmcwParameters
    cpi_chirps : int, optional
        Chirps per CPI (default :func:`default_cpi_chirps`).
    range_bin : int, optional
        A fixed range bin instead of following the moving target (the track's
        range is then the bin's, refined within it per CPI).
    max_step_bins : int
        Largest move of the target between CPIs [bins].
    beat_sign : {"positive", "negative"}
    source : str or Path
        Names the input in errors.
    """
    cube = cube_array(cube, source, "cube")
    if beat_sign not in BEAT_SIGNS:
        raise InputError(source, "beat_sign", f"is {beat_sign!r}", " or ".join(BEAT_SIGNS))
    check_timing(params, source)
    cpi = int(cpi_chirps or default_cpi_chirps(params.chirp_rate_hz))
    if cpi < 8:
        raise InputError(source, "cpi_chirps", f"is {cpi}", "at least 8 chirps per CPI")
    if cube.shape[0] < 2 * cpi:
        raise InputError(
            source,
            "cube",
            f"holds {cube.shape[0]} chirps",
            f"at least 2 CPIs of cpi_chirps={cpi} ({2 * cpi} chirps; a smaller --cpi-chirps)",
        )
    blocks = cpi_blocks(cube.shape[0], cpi)
    n_cpi = len(blocks)
    power = moving_power(cube, params, cpi, beat_sign=beat_sign)
    if range_bin is not None:
        if not 1 <= range_bin < params.n_bins:
            raise InputError(
                source,
                "range_bin",
                f"is {range_bin}",
                f"a bin in 1-{params.n_bins - 1} (of the "
                f"{params.n_bins} range bins of {params.range_bin_m:.3g} m up to "
                f"{params.max_range_m:.3g} m)",
            )
        bins = np.full(n_cpi, int(range_bin))
    else:
        bins = track_range_bins(power, max_step_bins=max_step_bins)
    t = np.array([(sl.start + sl.stop) / 2 for sl in blocks]) / params.chirp_rate_hz
    pos = sub_bin_position(bins, power)
    position = None
    if range_bin is None:
        smooth, _ = _local_fit(t, pos, _fit_half(params, cpi))
        t_chirp = np.arange(cube.shape[0]) / params.chirp_rate_hz
        position = np.interp(t_chirp, t, smooth)
    iq, w = bin_slow_time(cube, params, bins, cpi, beat_sign=beat_sign, position=position)
    rng = np.maximum(pos, 0.5) * params.range_bin_m
    v, from_dop = radial_velocity(t, rng, iq, params, cpi)
    trk = {
        "time_s": t,
        "range_m": rng,
        "radial_velocity_mps": v,
        "range_bin": bins.astype(int),
        "velocity_from_doppler": from_dop,
    }
    tiny = np.finfo(np.float64).tiny
    med = np.median(power[:, 1:], axis=1)
    contrast = 10 * np.log10(np.maximum(power[np.arange(n_cpi), bins], tiny) / np.maximum(med, tiny))
    info = {
        "n_chirps": int(cube.shape[0]),
        "n_samples": int(cube.shape[1]),
        "n_channels": int(cube.shape[2]),
        "input": "complex" if np.iscomplexobj(cube) else "real",
        "beat_sign": beat_sign,
        "chirp_rate_hz": params.chirp_rate_hz,
        "bandwidth_hz": params.bandwidth_hz,
        "sample_rate_hz": params.sample_rate_hz,
        "nfft": params.nfft,
        "range_bin_m": params.range_bin_m,
        "cpi_chirps": cpi,
        "n_cpi": n_cpi,
        "range_bin": "fixed" if range_bin is not None else "followed",
        "max_step_bins": max_step_bins,
        "bins_min": int(bins.min()),
        "bins_max": int(bins.max()),
        "moving_contrast_db_median": round(float(np.median(contrast)), 2),
        "velocity_from_doppler_fraction": round(float(np.mean(from_dop)), 3),
    }
    return FmcwResult(iq=iq, track=trk, bins=bins, position=position, weights=w, power=power, info=info)


def background_slow_time(
    cube: np.ndarray, params: FmcwParameters, result: FmcwResult, *, beat_sign: str = "positive", source="background"
) -> np.ndarray:
    """A target-free cube through the same cells and channel weights as ``result``.

    Returns
    -------
    ndarray, complex64 [n_chirps]
    """
    cube = cube_array(cube, source, "cube")
    n = len(result.iq)
    if cube.shape[0] != n:
        raise InputError(
            source,
            "chirps",
            f"has {cube.shape[0]}",
            f"{n} chirps, as the recording (background/iq pairs pulse by pulse)",
        )
    if cube.shape[1:] != (result.info["n_samples"], result.info["n_channels"]):
        raise InputError(
            source,
            "shape",
            f"is {cube.shape}",
            f"[{n}, {result.info['n_samples']}, {result.info['n_channels']}] as the recording",
        )
    iq, _ = bin_slow_time(
        cube,
        params,
        result.bins,
        int(result.info["cpi_chirps"]),
        beat_sign=beat_sign,
        position=result.position,
        weights=result.weights,
    )
    return iq
