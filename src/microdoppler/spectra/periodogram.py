"""The one windowed periodogram (short-time Fourier transform) of slow-time samples.

Every power spectrum of a radar's slow-time series in the package runs here: the
paper's spectrogram (:func:`microdoppler.spectra.spectrogram`), the
calibration's STFT columns, the diagnosis's periodogram, the rotor estimator's,
the plausibility check's and the import's I/Q-balance spectra. :func:`stft` cuts a 1-D complex series into CPIs
(coherent processing intervals) of ``n_fft`` pulses, removes each CPI's mean if
asked, multiplies by the analysis window and takes the FFT; :func:`periodogram`
squares it into power, optionally scaled by the window's energy and averaged over
CPIs. :func:`window` is the analysis window itself (periodic Blackman-Harris by
default), for code that needs its sums or weights rather than a spectrum.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.fft as sfft
from scipy.signal import get_window

#: the analysis window of every periodogram unless a caller names another
DEFAULT_WINDOW = "blackmanharris"


@lru_cache(maxsize=32)
def _window(name: str, n_fft: int) -> np.ndarray:
    w = get_window(name, n_fft, fftbins=True)
    w.flags.writeable = False
    return w


def window(n_fft: int, name: str = DEFAULT_WINDOW) -> np.ndarray:
    """The periodic (DFT-even) analysis window of ``n_fft`` pulses.

    Parameters
    ----------
    n_fft : int
        Window length [pulses].
    name : str
        A window name :func:`scipy.signal.get_window` knows (without parameters),
        default ``DEFAULT_WINDOW``, "blackmanharris" (4-term Blackman-Harris, -92 dB sidelobes).

    Returns
    -------
    ndarray, float64 [n_fft]
        The window (a fresh copy), ``get_window(name, n_fft, fftbins=True)``, equal to
        ``scipy.signal.windows.blackmanharris(n_fft, sym=False)`` by default.

    Examples
    --------
    >>> from microdoppler.spectra import window
    >>> w = window(4096)
    >>> w.shape, round(float(w.max()), 6), round(float((w**2).sum() / len(w)), 4)
    ((4096,), 1.0, 0.258)
    """
    return _window(str(name), int(n_fft)).copy()


def cpi_starts(n_pulses: int, n_fft: int, hop: int) -> np.ndarray:
    """First pulse of every CPI of ``n_fft`` pulses at ``hop`` wholly inside a record
    of ``n_pulses`` pulses, the first at pulse 0: int64 [1 + (n_pulses - n_fft) // hop]
    (empty when the record is shorter than one CPI)."""
    if n_pulses < n_fft:
        return np.zeros(0, np.int64)
    return np.arange(1 + (int(n_pulses) - int(n_fft)) // int(hop), dtype=np.int64) * int(hop)


def stft(
    x: np.ndarray,
    n_fft: int,
    *,
    hop: int | None = None,
    starts: np.ndarray | None = None,
    window: str | np.ndarray = DEFAULT_WINDOW,
    demean: bool = False,
    shift: bool = False,
    bins: np.ndarray | slice | None = None,
    dtype=np.complex128,
    workers: int = 1,
) -> np.ndarray:
    """Windowed FFT of every CPI of ``x``: the complex short-time Fourier transform.

    Parameters
    ----------
    x : ndarray, complex [n_pulses]
        Slow-time samples, one per pulse.
    n_fft : int
        CPI length = FFT length [pulses].
    hop : int, optional
        Pulses between successive CPIs (default ``n_fft // 2``); the CPIs start at
        pulse 0 and lie wholly inside ``x`` (``cpi_starts``). Ignored with ``starts``.
    starts : ndarray of int, optional
        First pulse of each CPI instead (each CPI must lie inside ``x``).
    window : str or ndarray
        The analysis window's name (:func:`window`, periodic) or the window itself
        (float [n_fft]; a float32 window with ``dtype=np.complex64`` keeps single
        precision throughout).
    demean : bool
        Subtract each CPI's mean before windowing (removes a static clutter line
        before its sidelobes reach every bin).
    shift : bool
        Centre 0 Hz (``fftshift``: bin ``j`` is Doppler ``(j - n_fft // 2) PRF / n_fft``);
        otherwise FFT order (bin ``k`` is ``k PRF / n_fft``, folded at PRF / 2).
    bins : ndarray of int or slice, optional
        Bins to keep, indices into the (shifted or unshifted) spectrum; default all.
    dtype : numpy dtype
        Complex precision of the frames and the FFT (default complex128: ``x`` is
        promoted before windowing).
    workers : int
        Threads of :func:`scipy.fft.fft`.

    Returns
    -------
    ndarray, ``dtype`` [n_cpis, n_bins]
        The complex spectrum of each CPI, uncalibrated (the window is not normalised):
        a tone of amplitude A at a bin's centre reads ``A sum(w)`` there.

    Raises
    ------
    ValueError
        When ``x`` is not 1-D or holds no whole CPI, or ``window`` has not ``n_fft``
        samples.

    See Also
    --------
    periodogram, window

    Examples
    --------
    Two CPIs of 256 pulses of a tone in bin 10, centred (0 Hz in bin 128):

    >>> import numpy as np
    >>> from microdoppler.spectra import stft
    >>> x = np.exp(2j * np.pi * 10 * np.arange(512) / 256)
    >>> X = stft(x, 256, hop=256, shift=True)
    >>> X.shape, X.dtype, np.abs(X).argmax(axis=1).tolist()
    ((2, 256), dtype('complex128'), [138, 138])
    """
    x = np.asarray(x)
    if x.ndim != 1:
        raise ValueError(f"x must be 1-D, got shape {x.shape}")
    n_fft = int(n_fft)
    if starts is None:
        starts = cpi_starts(len(x), n_fft, n_fft // 2 if hop is None else hop)
        if not len(starts):
            raise ValueError(f"x has {len(x)} pulses, fewer than n_fft={n_fft}")
    starts = np.asarray(starts, np.int64)
    w = _window(window, n_fft) if isinstance(window, str) else np.asarray(window)
    if w.shape != (n_fft,):
        raise ValueError(f"window has shape {w.shape}, not ({n_fft},)")
    frames = np.asarray(x, dtype)[starts[:, None] + np.arange(n_fft, dtype=np.int64)[None, :]]
    if demean:
        frames -= frames.mean(axis=1, keepdims=True)
    frames *= w
    X = sfft.fft(frames, axis=1, workers=workers, overwrite_x=True)
    if shift:
        X = sfft.fftshift(X, axes=1)
    return X if bins is None else X[:, bins]


def periodogram(
    x: np.ndarray,
    n_fft: int,
    *,
    hop: int | None = None,
    starts: np.ndarray | None = None,
    window: str | np.ndarray = DEFAULT_WINDOW,
    demean: bool = False,
    shift: bool = False,
    bins: np.ndarray | slice | None = None,
    scale: bool = False,
    average: bool = False,
    dtype=np.complex128,
    workers: int = 1,
) -> np.ndarray:
    """Windowed periodogram of every CPI of ``x``: ``|stft|^2``.

    Parameters
    ----------
    x, n_fft, hop, starts, window, demean, shift, bins, dtype, workers
        As :func:`stft`.
    scale : bool
        Divide by the window's energy ``sum(w^2)``: white noise of variance sigma^2
        per pulse then reads sigma^2 in every bin on average, and a tone of amplitude
        A at a bin's centre reads ``A^2 sum(w)^2 / sum(w^2)``.
    average : bool
        Return the mean over CPIs (Welch's average) instead of each CPI's power.

    Returns
    -------
    ndarray, float [n_cpis, n_bins], or [n_bins] with ``average``
        Power ``re^2 + im^2`` of each bin (the squared amplitude of :func:`stft`;
        units of ``|x|^2``, times ``sum(w^2)`` unless ``scale``).

    See Also
    --------
    stft, window, microdoppler.spectra.spectrogram

    Examples
    --------
    A unit tone in bin 100 of a 1024-pulse CPI reads the window's coherent gain
    ``sum(w)^2`` there; scaled by the energy, white noise reads its variance:

    >>> import numpy as np
    >>> from microdoppler.spectra import periodogram, window
    >>> n = 1024
    >>> tone = np.exp(2j * np.pi * 100 * np.arange(4 * n) / n)
    >>> p = periodogram(tone, n)
    >>> p.shape, int(p[0].argmax()), bool(np.isclose(p[0, 100], window(n).sum() ** 2))
    ((7, 1024), 100, True)
    >>> rng = np.random.default_rng(0)
    >>> noise = 2.0 * (rng.standard_normal(400 * n) + 1j * rng.standard_normal(400 * n)) / np.sqrt(2)
    >>> round(float(periodogram(noise, n, scale=True, average=True).mean()), 1)
    4.0
    """
    X = stft(
        x,
        n_fft,
        hop=hop,
        starts=starts,
        window=window,
        demean=demean,
        shift=shift,
        bins=bins,
        dtype=dtype,
        workers=workers,
    )
    p = X.real**2 + X.imag**2
    if scale:
        w = _window(window, int(n_fft)) if isinstance(window, str) else np.asarray(window)
        p = p / (w**2).sum()
    return p.mean(axis=0) if average else p
