"""Spectrograms as in the paper (§II, §III.C): 15 Hz high-pass, 4096-point
Blackman-Harris STFT with 50 % overlap, the central 480 Doppler bins, in dB; and
20-timestep image tiles.

Two levels of settings:

- :class:`SpectrogramConfig` is what the STFT runs on, in pulses and bins (``n_fft``,
  ``n_bins``). Its defaults are the paper's radar (PRF 7.3 kHz, 1.35 GHz).
- :class:`SpectrogramSettings` states the same in physical units (the CPI in
  seconds, the image's Doppler span in Hz or m/s, or the blade tips to cover) and
  :meth:`SpectrogramSettings.resolve` turns them into a :class:`SpectrogramConfig`
  for a radar's PRF and carrier. With no setting given it follows the paper: the CPI
  is the power of two nearest 0.56 s x PRF and the image spans ±47.5 m/s of radial
  velocity, which for the paper's radar is exactly 4096 pulses and 480 bins.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.fft as sfft
from scipy.signal import butter, sosfiltfilt

from ..errors import ConfigError
from .periodogram import periodogram
from ..configfields import check_keys, config_names, knob

#: speed of light [m/s]
C_MPS = 299_792_458.0
#: the paper's CPI [s] (§II: 4096 pulses at ~7.3 kHz): the CPI is the power of two
#: nearest ``window_s`` x PRF pulses
PAPER_WINDOW_S = 0.56
#: the paper's image width in radial velocity [m/s], full span centred on 0 (±47.5
#: m/s): its 480 central bins of 7300 / 4096 Hz at 1.35 GHz are 855.5 Hz = 94.99 m/s
#: (lambda / 2 per Hz). A fixed velocity window shows the same body speeds and the same
#: share of the blade tips' extent (both scale as 1 / lambda) at every carrier.
PAPER_DOPPLER_SPAN_MPS = 95.0


@dataclass(frozen=True)
class SpectrogramConfig:
    """STFT settings.

    Parameters
    ----------
    n_fft : int
        Window length = FFT length [pulses] (one CPI).
    overlap : float
        Fraction of overlap between successive CPIs.
    highpass_hz : float
        High-pass cut-off removing stationary clutter (0 disables).
    n_bins : int
        Central Doppler bins kept (0 keeps all).
    highpass_order : int
        Order of the Butterworth high-pass (applied forwards and backwards).
    tile_timesteps : int
        Timesteps per image tile.

    Raises
    ------
    microdoppler.errors.ConfigError
        When a setting is out of its range (naming the ``spectrogram.*`` key).

    See Also
    --------
    spectrogram

    Examples
    --------
    >>> from microdoppler.spectra import SpectrogramConfig
    >>> cfg = SpectrogramConfig()
    >>> cfg.hop, cfg.doppler_bin_hz(7300.0), round(cfg.tile_duration_s(7300.0), 2)
    (2048, 1.7822265625, 5.89)
    """

    n_fft: int = 4096
    overlap: float = 0.5
    highpass_hz: float = 15.0
    highpass_order: int = 4
    n_bins: int = 480
    tile_timesteps: int = 20

    def __post_init__(self):
        if self.n_fft < 16:
            raise ConfigError("config", "spectrogram.n_fft", f"is {self.n_fft}", ">= 16 pulses")
        if not 0 <= self.overlap < 1:
            raise ConfigError("config", "spectrogram.overlap", f"is {self.overlap}", "in [0, 1)")
        if self.highpass_hz < 0:
            raise ConfigError("config", "spectrogram.highpass_hz", f"is {self.highpass_hz}", ">= 0 Hz")
        if not 0 <= self.n_bins <= self.n_fft:
            raise ConfigError("config", "spectrogram.n_bins", f"is {self.n_bins}", f"in [0, n_fft={self.n_fft}]")
        if self.tile_timesteps < 1:
            raise ConfigError("config", "spectrogram.tile_timesteps", f"is {self.tile_timesteps}", ">= 1")

    @property
    def hop(self) -> int:
        return int(round(self.n_fft * (1 - self.overlap)))

    def tile_duration_s(self, prf_hz: float) -> float:
        """Time spanned by one tile: (T - 1) hops + one window (§V.C: ~5.8 s)."""
        return ((self.tile_timesteps - 1) * self.hop + self.n_fft) / prf_hz

    def doppler_bin_hz(self, prf_hz: float) -> float:
        """Width of one Doppler bin at ``prf_hz`` [Hz]: PRF / n_fft."""
        return prf_hz / self.n_fft

    def doppler_span_hz(self, prf_hz: float) -> float:
        """Full Doppler width of the images at ``prf_hz`` [Hz] (the whole PRF with n_bins 0)."""
        return (self.n_bins or self.n_fft) * self.doppler_bin_hz(prf_hz)


def blade_tip_doppler_hz(rev_s: float, blade_length_m: float, carrier_hz: float) -> float:
    """Largest micro-Doppler of a blade tip about the body line [Hz].

    The tip moves at 2 pi rev_s L; its two-way Doppler is 2 v / lambda, so
    ``4 pi rev_s L / lambda`` (lambda = c / carrier_hz).
    """
    return 4 * math.pi * rev_s * blade_length_m * carrier_hz / C_MPS


def blade_tip_reach_hz(rev_s: float, blade_length_m: float, carrier_hz: float, body_mps: float = 0.0) -> float:
    """Largest |Doppler| of a rotor's echo about 0 Hz that an image must hold [Hz].

    The tip's excursion :func:`blade_tip_doppler_hz` is a sinusoidal phase modulation
    at the rotation rate, so its lines spill past it; Carson's rule adds one
    modulation frequency (``rev_s``) to hold ~98 % of the power. The body's Doppler
    2 |body_mps| / lambda shifts it all (images are centred on 0 Hz, not on the body).
    """
    return blade_tip_doppler_hz(rev_s, blade_length_m, carrier_hz) + rev_s + 2 * abs(body_mps) * carrier_hz / C_MPS


def nearest_power_of_two(x: float) -> int:
    """The power of two nearest ``x`` on a log scale: 2 ** round(log2 x)."""
    return int(2 ** round(math.log2(x)))


def _number(key: str, value, *, integer: bool = False):
    """``value`` of setting ``spectrogram.<key>`` as a float (int), or ConfigError."""
    bad = isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating))
    if not bad and integer and float(value) != int(value):
        bad = True
    if bad or not math.isfinite(float(value)):
        raise ConfigError(
            "config", f"spectrogram.{key}", f"is {value!r}", "an integer" if integer else "a finite number"
        )
    return int(value) if integer else float(value)


@dataclass(frozen=True)
class SpectrogramSettings:
    """Spectrogram and image settings in physical units (config ``spectrogram``).

    ``None`` means "not given". The CPI comes from ``window_s`` or ``n_fft`` (at
    most one; neither: :data:`PAPER_WINDOW_S`); the image's Doppler width from one of
    ``doppler_span_hz``, ``doppler_span_mps``, ``blade_tip_rev_s`` or ``n_bins``
    (neither: :data:`PAPER_DOPPLER_SPAN_MPS`). ``n_fft`` and ``n_bins`` are explicit
    overrides in pulses and bins; they ignore the radar.

    Parameters
    ----------
    window_s : float, optional
        Target CPI [s]; the STFT length is the power of two nearest window_s x PRF
        (0.56 s -> 4096 pulses for PRFs from 5.2 to 10.3 kHz).
    n_fft : int, optional
        STFT length [pulses], overriding ``window_s``.
    doppler_span_hz : float, optional
        Full Doppler width of the image, centred on 0 Hz [Hz]; at most the PRF.
    doppler_span_mps : float, optional
        The same in radial velocity [m/s] (Hz = 2 v / lambda); at most PRF x lambda / 2.
    blade_tip_rev_s : float, optional
        Cover the blade tips at this rotation rate [rev/s]: the image spans
        ±(4 pi rev_s L / lambda + rev_s + 2 |v_body| / lambda)
        (:func:`blade_tip_reach_hz`) for the blade length L and body speed given to
        :meth:`resolve`, clipped to ±PRF / 2.
    n_bins : int, optional
        Central Doppler bins kept (0 keeps all), overriding the spans.
    overlap, highpass_hz, highpass_order, tile_timesteps
        As :class:`SpectrogramConfig`.
    """

    window_s: float | None = knob(
        None,
        "Target CPI [s]: the STFT length is the power of two nearest window_s x PRF pulses. null: 0.56 s (the "
        "paper's 4096 pulses at 7.3 kHz).",
        exclusive_minimum=0,
    )
    n_fft: int | None = knob(
        None,
        "STFT length [pulses], an explicit override of window_s that ignores the PRF. null: from window_s.",
        minimum=16,
    )
    doppler_span_hz: float | None = knob(
        None,
        "Full Doppler width of the images, centred on 0 Hz [Hz], at most the PRF; rounded to the nearest even "
        "number of bins. null: see doppler_span_mps.",
        exclusive_minimum=0,
    )
    doppler_span_mps: float | None = knob(
        None,
        "Full width of the images in radial velocity [m/s] (Hz = 2 v / wavelength), at most PRF x wavelength / 2. "
        "null with no other span: 95 m/s (the paper's 480 bins at 1.35 GHz, clipped to the PRF).",
        exclusive_minimum=0,
    )
    blade_tip_rev_s: float | None = knob(
        None,
        "Cover the blade tips at this rotation rate [rev/s]: the images span ±(4 pi rate L / wavelength + rate + 2 "
        "|v| / wavelength) (the tips' micro-Doppler, Carson's one-rate margin, the body Doppler) for the longest "
        "blade_length_m and fastest track radial speed v of the drone flights, clipped to ±PRF/2. null: off.",
        exclusive_minimum=0,
    )
    n_bins: int | None = knob(
        None,
        "Central Doppler bins kept (0: all), an explicit override of the spans that ignores the PRF and carrier. "
        "null: from the span.",
        minimum=0,
    )
    overlap: float = knob(0.5, "Overlap of successive CPIs.", minimum=0, exclusive_maximum=1)
    highpass_hz: float = knob(15.0, "High-pass cut-off removing slow clutter [Hz].", minimum=0)
    highpass_order: int = knob(4, "Order of the Butterworth high-pass (applied forwards and backwards).", minimum=1)
    tile_timesteps: int = knob(20, "Timesteps (CPIs) per image.", minimum=1)

    #: the settings that give the image's Doppler width (at most one)
    SPAN_KEYS = ("doppler_span_hz", "doppler_span_mps", "blade_tip_rev_s", "n_bins")

    def __post_init__(self):
        for key, unit in (
            ("window_s", "s"),
            ("doppler_span_hz", "Hz"),
            ("doppler_span_mps", "m/s"),
            ("blade_tip_rev_s", "rev/s"),
        ):
            v = getattr(self, key)
            if v is not None and not _number(key, v) > 0:
                raise ConfigError("config", f"spectrogram.{key}", f"is {v}", f"> 0 {unit}")
        if self.n_fft is not None and _number("n_fft", self.n_fft, integer=True) < 16:
            raise ConfigError("config", "spectrogram.n_fft", f"is {self.n_fft}", ">= 16 pulses")
        if self.n_bins is not None and _number("n_bins", self.n_bins, integer=True) < 0:
            raise ConfigError("config", "spectrogram.n_bins", f"is {self.n_bins}", ">= 0 (0 keeps all bins)")
        if self.window_s is not None and self.n_fft is not None:
            raise ConfigError(
                "config",
                "spectrogram.window_s",
                f"is {self.window_s} and n_fft is {self.n_fft}",
                "one of window_s [s] or n_fft [pulses]",
            )
        given = [k for k in self.SPAN_KEYS if getattr(self, k) is not None]
        if len(given) > 1:
            raise ConfigError(
                "config", f"spectrogram.{given[1]}", f"is given with {given[0]}", "one of " + ", ".join(self.SPAN_KEYS)
            )
        # the fixed settings: SpectrogramConfig's own checks, on its default bins
        SpectrogramConfig(
            overlap=_number("overlap", self.overlap),
            highpass_hz=_number("highpass_hz", self.highpass_hz),
            highpass_order=_number("highpass_order", self.highpass_order, integer=True),
            tile_timesteps=_number("tile_timesteps", self.tile_timesteps, integer=True),
        )

    @classmethod
    def from_config(cls, spectrogram: dict | None, source="config") -> "SpectrogramSettings":
        """Settings from the config's ``spectrogram`` mapping; an unknown key is a
        one-line :class:`~microdoppler.errors.ConfigError` naming it and the section."""
        return cls(**check_keys(spectrogram, config_names(cls), "spectrogram", source))

    def resolve(
        self, prf_hz: float, carrier_hz: float, *, blade_length_m: float | None = None, body_mps: float = 0.0
    ) -> SpectrogramConfig:
        """The STFT settings in pulses and bins for a radar of ``prf_hz`` and ``carrier_hz``.

        Parameters
        ----------
        prf_hz, carrier_hz : float
            The radar's pulse repetition frequency and carrier [Hz].
        blade_length_m : float, optional
            Longest blade (hub to tip) of the drones to cover [m]; needed with
            ``blade_tip_rev_s``.
        body_mps : float
            Fastest body radial speed of those drones [m/s] (the images are centred on
            0 Hz, not on the body); only with ``blade_tip_rev_s``.

        Returns
        -------
        SpectrogramConfig
            ``n_fft`` = ``n_fft`` or the power of two nearest window_s x PRF;
            ``n_bins`` = ``n_bins``, or the even number of bins nearest the span
            (``doppler_span_hz``, ``doppler_span_mps``, default
            :data:`PAPER_DOPPLER_SPAN_MPS` clipped to the PRF), or with
            ``blade_tip_rev_s`` the fewest even bins whose Doppler reaches
            ±:func:`blade_tip_reach_hz` (all bins when that passes ±PRF / 2).

        Raises
        ------
        ConfigError
            Naming the setting: a CPI under 16 pulses, a given span wider than the
            PRF or narrower than two bins, ``n_bins`` > ``n_fft``, ``blade_tip_rev_s``
            without ``blade_length_m``.
        """
        if not (math.isfinite(prf_hz) and prf_hz > 0):
            raise ConfigError("radar", "prf_hz", f"is {prf_hz}", "> 0 Hz")
        if not (math.isfinite(carrier_hz) and carrier_hz > 0):
            raise ConfigError("radar", "carrier_hz", f"is {carrier_hz}", "> 0 Hz")
        wavelength_m = C_MPS / carrier_hz
        if self.n_fft is not None:
            n_fft = int(self.n_fft)
        else:
            window_s = PAPER_WINDOW_S if self.window_s is None else self.window_s
            n_fft = nearest_power_of_two(window_s * prf_hz)
            if n_fft < 16:
                raise ConfigError(
                    "config",
                    "spectrogram.window_s",
                    f"is {window_s} s = {window_s * prf_hz:.1f} pulses at PRF {prf_hz:g} Hz",
                    ">= 16 pulses",
                )
        bin_hz = prf_hz / n_fft
        if self.n_bins is not None:
            n_bins = int(self.n_bins)
            if n_bins > n_fft:
                raise ConfigError("config", "spectrogram.n_bins", f"is {n_bins}", f"<= n_fft = {n_fft}")
        elif self.blade_tip_rev_s is not None:
            if blade_length_m is None or not blade_length_m > 0:
                raise ConfigError(
                    "config",
                    "spectrogram.blade_tip_rev_s",
                    f"is {self.blade_tip_rev_s} with blade length {blade_length_m}",
                    "a blade length > 0 m (the data's drones)",
                )
            reach_hz = blade_tip_reach_hz(self.blade_tip_rev_s, blade_length_m, carrier_hz, body_mps)
            # centred bins k - n_fft/2 .. : n_bins reach from -n_bins/2 to n_bins/2 - 1 bins
            n_bins = min(2 * (math.ceil(reach_hz / bin_hz) + 1), n_fft)
        else:
            if self.doppler_span_hz is not None:
                key, span_hz = "doppler_span_hz", float(self.doppler_span_hz)
            elif self.doppler_span_mps is not None:
                key, span_hz = "doppler_span_mps", 2 * float(self.doppler_span_mps) / wavelength_m
            else:
                key, span_hz = None, min(2 * PAPER_DOPPLER_SPAN_MPS / wavelength_m, prf_hz)
            if key is not None and span_hz > prf_hz * (1 + 1e-12):
                v = getattr(self, key)
                raise ConfigError(
                    "config",
                    f"spectrogram.{key}",
                    f"is {v} = {span_hz:.1f} Hz at {carrier_hz:g} Hz",
                    f"<= the PRF, {prf_hz:g} Hz = {prf_hz * wavelength_m / 2:.2f} m/s (Doppler beyond ±PRF/2 folds)",
                )
            n_bins = min(2 * math.floor(span_hz / bin_hz / 2 + 0.5), n_fft)
            if n_bins < 2:
                raise ConfigError(
                    "config",
                    f"spectrogram.{key or 'doppler_span_mps'}",
                    f"gives {span_hz:.3g} Hz",
                    f">= two Doppler bins, {2 * bin_hz:.3g} Hz",
                )
        return SpectrogramConfig(
            n_fft=n_fft,
            overlap=float(self.overlap),
            highpass_hz=float(self.highpass_hz),
            highpass_order=int(self.highpass_order),
            n_bins=n_bins,
            tile_timesteps=int(self.tile_timesteps),
        )


def describe(cfg: SpectrogramConfig, prf_hz: float, carrier_hz: float) -> dict:
    """The resolved settings in physical units (CPI, bin width, image span in Hz and m/s)."""
    span_hz = cfg.doppler_span_hz(prf_hz)
    return dict(
        prf_hz=float(prf_hz),
        carrier_hz=float(carrier_hz),
        n_fft=cfg.n_fft,
        cpi_s=cfg.n_fft / prf_hz,
        n_bins=cfg.n_bins,
        doppler_bin_hz=cfg.doppler_bin_hz(prf_hz),
        doppler_span_hz=span_hz,
        doppler_span_mps=span_hz * C_MPS / carrier_hz / 2,
        tile_duration_s=cfg.tile_duration_s(prf_hz),
    )


@dataclass
class Spectrogram:
    """Power spectrogram.

    Attributes
    ----------
    power_db : ndarray, float32 [n_timesteps, n_bins]
        10 log10 |STFT|^2 (uncalibrated, relative).
    time_s : ndarray [n_timesteps]
        Centre time of each CPI [s].
    doppler_hz : ndarray [n_bins]
        Doppler of each bin [Hz]; positive = approaching.

    See Also
    --------
    spectrogram, line_snr_db

    Examples
    --------
    >>> import numpy as np
    >>> from microdoppler.spectra import spectrogram
    >>> iq = np.exp(2j * np.pi * 100.0 * np.arange(8192) / 7300.0).astype(np.complex64)
    >>> spec = spectrogram(iq, 7300.0)
    >>> spec.power_db.shape, round(spec.bin_hz, 3)
    ((3, 480), 1.782)
    """

    power_db: np.ndarray
    time_s: np.ndarray
    doppler_hz: np.ndarray

    @property
    def bin_hz(self) -> float:
        return float(self.doppler_hz[1] - self.doppler_hz[0])


def highpass(iq: np.ndarray, prf_hz: float, cutoff_hz: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth high-pass of complex slow-time samples."""
    if cutoff_hz <= 0:
        return iq
    sos = butter(order, cutoff_hz, btype="highpass", fs=prf_hz, output="sos")
    return sosfiltfilt(sos, iq).astype(np.complex64)


def spectrogram(iq: np.ndarray, prf_hz: float, cfg: SpectrogramConfig = SpectrogramConfig()) -> Spectrogram:
    """Paper spectrogram of slow-time ``iq``: 15 Hz high-pass, Blackman-Harris STFT.

    Windows lie wholly inside the record (no zero padding at the ends), so the
    number of timesteps is ``1 + (n_pulses - n_fft) // hop``.

    Parameters
    ----------
    iq : ndarray, complex64 [n_pulses]
        Slow-time samples, one per pulse.
    prf_hz : float
        Pulse repetition frequency [Hz].
    cfg : SpectrogramConfig
        STFT settings (default: the paper's 4096 points, 50 % overlap, 480 bins).

    Returns
    -------
    Spectrogram
        ``power_db`` float32 [n_timesteps, n_bins] (relative dB), ``time_s``
        [n_timesteps] (CPI centres [s]) and ``doppler_hz`` [n_bins] (bin centres [Hz],
        positive approaching).

    Raises
    ------
    ValueError
        When ``iq`` is not 1-D or is shorter than one window.

    See Also
    --------
    SpectrogramConfig, line_snr_db

    Examples
    --------
    A tone at 100 Hz peaks in the bin nearest 100 Hz:

    >>> import numpy as np
    >>> from microdoppler.spectra import spectrogram
    >>> iq = np.exp(2j * np.pi * 100.0 * np.arange(4 * 4096) / 7300.0).astype(np.complex64)
    >>> spec = spectrogram(iq, prf_hz=7300.0)
    >>> spec.power_db.shape, spec.power_db.dtype
    ((7, 480), dtype('float32'))
    >>> round(float(spec.doppler_hz[spec.power_db[0].argmax()]), 1)
    99.8
    """
    iq = np.asarray(iq)
    if iq.ndim != 1 or len(iq) < cfg.n_fft:
        raise ValueError(f"iq must be 1-D with >= n_fft={cfg.n_fft} pulses, got shape {iq.shape}")
    x = highpass(iq, prf_hz, cfg.highpass_hz, cfg.highpass_order)
    starts, t, f = cpi_grid(len(x), prf_hz, cfg)
    if not len(starts):
        raise ValueError(f"no CPI of {cfg.n_fft} pulses centred on a multiple of hop={cfg.hop} fits {len(x)} pulses")
    keep = slice(None)
    if cfg.n_bins:
        lo = cfg.n_fft // 2 - cfg.n_bins // 2
        keep = slice(lo, lo + cfg.n_bins)
    p = periodogram(x, cfg.n_fft, starts=starts, shift=True, bins=keep)
    return Spectrogram(10 * np.log10(p + 1e-30).astype(np.float32), t, f[keep])


def cpi_grid(n_pulses: int, prf_hz: float, cfg: SpectrogramConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The spectrogram's CPIs in a record of ``n_pulses`` pulses and its Doppler axis.

    CPI ``p`` is centred on pulse ``p * hop`` (its window's sample ``n_fft // 2``);
    only the CPIs wholly inside the record count (no zero padding at the ends).

    Parameters
    ----------
    n_pulses : int
        Record length [pulses].
    prf_hz : float
        Pulse repetition frequency [Hz].
    cfg : SpectrogramConfig
        STFT settings (``n_fft``, ``hop``).

    Returns
    -------
    starts : ndarray, int64 [n_timesteps]
        First pulse of each CPI's window.
    time_s : ndarray, float64 [n_timesteps]
        Centre time of each CPI [s] (``p * hop / prf_hz``).
    doppler_hz : ndarray, float64 [n_fft]
        Doppler of each bin of the centred (``fftshift``-ed) spectrum [Hz].
    """
    n, hop, mid = int(cfg.n_fft), int(cfg.hop), int(cfg.n_fft) // 2
    p = np.arange(-(-mid // hop), (int(n_pulses) - n + mid) // hop + 1)
    return (
        p.astype(np.int64) * hop - mid,
        p * (hop * (1 / prf_hz)),
        sfft.fftshift(sfft.fftfreq(n, 1 / prf_hz)),
    )


def tiles(spec: Spectrogram, timesteps: int = 20) -> np.ndarray:
    """Non-overlapping images of ``timesteps`` CPIs: float32 [n_tiles, timesteps, n_bins]."""
    n = spec.power_db.shape[0] // timesteps
    return spec.power_db[: n * timesteps].reshape(n, timesteps, -1)
