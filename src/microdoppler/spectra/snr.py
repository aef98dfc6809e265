"""The one SNR measure of the project (Table III's definition).

Per spectrogram timestep: the target line's peak power over the spectrogram's median
noise floor, in dB. The target line is searched within ``search_hz`` of an expected
Doppler (the body Doppler from the track) or, without one, anywhere outside the
high-pass notch. The floor is the median over all bins of that timestep (robust to
the few bins a target occupies).
"""

from __future__ import annotations

import numpy as np

from .spectrogram import Spectrogram, SpectrogramConfig, spectrogram


def noise_floor_db(spec: Spectrogram) -> np.ndarray:
    """Median power of each timestep [dB], float [n_timesteps]."""
    return np.median(spec.power_db, axis=1)


def line_snr_db(
    spec: Spectrogram, expected_hz: np.ndarray | float | None = None, *, search_hz: float = 10.0, notch_hz: float = 20.0
) -> np.ndarray:
    """Peak of the line near ``expected_hz`` over the median floor, per timestep [dB].

    Parameters
    ----------
    spec : Spectrogram
    expected_hz : float or ndarray [n_timesteps], optional
        Doppler where the line is expected. ``None`` takes the strongest bin outside
        ±``notch_hz``.
    search_hz : float
        Half-width of the search window around ``expected_hz`` [Hz].
    notch_hz : float
        Without ``expected_hz``: lines within this of 0 Hz (clutter) are ignored [Hz].

    Returns
    -------
    ndarray, float64 [n_timesteps]
        The line's peak over the timestep's median floor [dB]; -inf where the search
        window holds no bin.

    See Also
    --------
    spectrogram

    Examples
    --------
    >>> import numpy as np
    >>> from microdoppler.spectra import line_snr_db, spectrogram
    >>> rng = np.random.default_rng(0)
    >>> n = 4 * 4096
    >>> iq = np.exp(2j * np.pi * 100.0 * np.arange(n) / 7300.0) + 0.01 * rng.standard_normal(n)
    >>> snr = line_snr_db(spectrogram(iq.astype(np.complex64), 7300.0), expected_hz=100.0)
    >>> snr.shape, bool(np.all(snr > 50))
    ((7,), True)
    """
    p = spec.power_db
    f = spec.doppler_hz
    floor = noise_floor_db(spec)
    if expected_hz is None:
        mask = np.abs(f) > notch_hz
        peak = p[:, mask].max(axis=1)
    else:
        e = np.broadcast_to(np.asarray(expected_hz, dtype=np.float64), (p.shape[0],))
        peak = np.empty(p.shape[0])
        for i in range(p.shape[0]):
            sel = np.abs(f - e[i]) <= search_hz
            peak[i] = p[i, sel].max() if sel.any() else -np.inf
    return peak - floor


def flight_snr_db(spec: Spectrogram, expected_hz=None, **kw) -> tuple[float, float]:
    """Mean and standard deviation over timesteps of :func:`line_snr_db` [dB]."""
    s = line_snr_db(spec, expected_hz, **kw)
    s = s[np.isfinite(s)]
    return float(np.mean(s)), float(np.std(s))


def body_doppler_hz(track_time_s, radial_velocity_mps, wavelength_m: float, time_s) -> np.ndarray:
    """Body Doppler [Hz] at ``time_s`` from the track (f = -2 v / lambda; + approaching)."""
    v = np.interp(np.asarray(time_s, float), np.asarray(track_time_s, float), np.asarray(radial_velocity_mps, float))
    return -2.0 * v / wavelength_m


#: the line a flight's SNR is measured on: the body line, or (a drone whose body sits in
#: the clutter notch: hovering, stand-mounted) the strongest rotor line
SNR_LINES = ("body", "rotor")


def snr_line(target: str, body_hz, *, highpass_hz: float, search_hz: float = 10.0) -> str:
    """Which line a record's SNR is measured on (:data:`SNR_LINES`).

    ``body``, unless the record is a drone (``target``) whose body Doppler ``body_hz``
    [n_timesteps, Hz] (from the track) lies within the clutter notch
    (``highpass_hz`` + ``search_hz``) at every timestep: then its body line is
    high-passed away and its rotor lines carry its signal (``rotor``)."""
    b = np.asarray(body_hz, float)
    notched = b.size > 0 and not np.any(np.isfinite(b) & (np.abs(b) > highpass_hz + search_hz))
    return "rotor" if target == "drone" and notched else "body"


def record_snr_db(spec: Spectrogram, body_hz, line: str, *, highpass_hz: float, search_hz: float = 10.0) -> np.ndarray:
    """SNR per timestep [dB] on ``line`` (:func:`snr_line`): the body line's within
    ``search_hz`` of ``body_hz``, or the strongest rotor line's (the strongest bin beyond
    the clutter notch, ``highpass_hz`` + ``search_hz`` from 0 Hz)."""
    if line == "rotor":
        return line_snr_db(spec, None, notch_hz=highpass_hz + search_hz)
    if line != "body":
        raise ValueError(f"line={line!r} must be one of {SNR_LINES}")
    return line_snr_db(spec, body_hz, search_hz=search_hz)


def flight_line_snr_db(
    flight, iq: np.ndarray | None = None, *, spec_cfg: SpectrogramConfig = SpectrogramConfig(), search_hz: float = 10.0
) -> tuple[np.ndarray, str]:
    """SNR of every spectrogram timestep of a flight on the line that carries its
    signal [dB], and that line's name (:func:`snr_line`): the body line
    (:func:`flight_body_snr_db`) unless the flight is a drone whose body sits in the
    clutter notch (hovering, stand-mounted), then its strongest rotor line."""
    iq = flight.iq if iq is None else iq
    if len(iq) < spec_cfg.n_fft:
        return np.empty(0), "body"
    spec = spectrogram(iq, flight.prf_hz, spec_cfg)
    body = body_doppler_hz(flight.track_time_s, flight.track_radial_velocity_mps, flight.wavelength_m, spec.time_s)
    line = snr_line(flight.attrs.get("target", ""), body, highpass_hz=spec_cfg.highpass_hz, search_hz=search_hz)
    return record_snr_db(spec, body, line, highpass_hz=spec_cfg.highpass_hz, search_hz=search_hz), line


def flight_body_snr_db(
    flight, iq: np.ndarray | None = None, *, spec_cfg: SpectrogramConfig = SpectrogramConfig(), search_hz: float = 10.0
) -> np.ndarray:
    """Body-line SNR of every spectrogram timestep of a flight (Table III's measure) [dB].

    ``flight`` is a :class:`~microdoppler.io.flightzarr.Flight`; ``iq`` (default the
    flight's own) is the signal to measure, e.g. a synthetic twin on the flight's track.
    Returns an empty array for records shorter than one CPI.
    """
    iq = flight.iq if iq is None else iq
    if len(iq) < spec_cfg.n_fft:
        return np.empty(0)
    spec = spectrogram(iq, flight.prf_hz, spec_cfg)
    body = body_doppler_hz(flight.track_time_s, flight.track_radial_velocity_mps, flight.wavelength_m, spec.time_s)
    return line_snr_db(spec, body, search_hz=search_hz)
