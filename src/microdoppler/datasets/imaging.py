"""The spectrogram settings of a dataset, resolved for the radar of its flights.

The config's ``spectrogram`` settings are physical (:class:`SpectrogramSettings`:
CPI in seconds, image span in Hz or m/s, or the blade tips to cover); every stage
that forms spectrograms of the measured flights or of their twins resolves them here,
once per dataset, into one :class:`SpectrogramConfig` (pulses and bins), so all images
of a dataset share their shape.

The radar is the flights' median PRF and carrier (one radar: its own). Flights whose
PRF would give another CPI length are refused (a mixture of radars needs an explicit
``n_fft``). With ``blade_tip_rev_s`` the span covers the longest blade
(``blade_length_m``) and the fastest track radial speed of the drone flights
(:func:`~microdoppler.spectra.spectrogram.blade_tip_reach_hz`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import ConfigError, InputError
from ..io.flightzarr import read_flight
from ..spectra.spectrogram import (
    PAPER_WINDOW_S,
    SpectrogramConfig,
    SpectrogramSettings,
    blade_tip_reach_hz,
    describe,
    nearest_power_of_two,
)


def flight_radars(measured_dir) -> list[dict]:
    """flight_id, prf_hz, carrier_hz, target, blade_length_m (drones, else None) and the
    fastest track radial speed [m/s] of every ``*.zarr`` store in ``measured_dir``."""
    measured_dir = Path(measured_dir)
    stores = sorted(measured_dir.glob("*.zarr"))
    if not stores:
        raise InputError(measured_dir, "directory", "holds no *.zarr stores", "flight-zarr/1 stores")
    rows = []
    for p in stores:
        fl = read_flight(p, load_iq=False, content=False)
        a = fl.attrs
        v = np.abs(np.asarray(fl.track_radial_velocity_mps, float))
        rows.append(
            dict(
                flight_id=fl.flight_id,
                prf_hz=fl.prf_hz,
                carrier_hz=fl.carrier_hz,
                target=a["target"],
                blade_length_m=float(a["blade_length_m"]) if a["target"] == "drone" else None,
                max_speed_mps=float(v.max()) if v.size else 0.0,
            )
        )
    return rows


def resolve_for_flights(
    settings: SpectrogramSettings | dict | None, radars: list[dict], *, source="measured", log=print
) -> SpectrogramConfig:
    """One :class:`SpectrogramConfig` for flights ``radars`` (rows of :func:`flight_radars`).

    Raises
    ------
    InputError
        Flights whose PRFs give different CPI lengths (with ``window_s``).
    ConfigError
        Bad settings (naming the key); ``blade_tip_rev_s`` with no drone flight.
    """
    s = settings if isinstance(settings, SpectrogramSettings) else SpectrogramSettings.from_config(settings)
    if not radars:
        raise InputError(source, "flights", "none", "at least one flight to take the radar from")
    prf = np.array([r["prf_hz"] for r in radars])
    carrier = np.array([r["carrier_hz"] for r in radars])
    prf_hz, carrier_hz = float(np.median(prf)), float(np.median(carrier))
    if s.n_fft is None:
        window_s = PAPER_WINDOW_S if s.window_s is None else s.window_s
        n = np.array([nearest_power_of_two(window_s * p) for p in prf])
        if len(set(n)) > 1:
            i, j = int(np.argmin(n)), int(np.argmax(n))
            raise InputError(
                source,
                "attrs.prf_hz",
                f"flights {radars[i]['flight_id']} ({prf[i]:g} Hz) and {radars[j]['flight_id']} "
                f"({prf[j]:g} Hz) give CPIs of {n[i]} and {n[j]} pulses for window_s {window_s:g} s",
                "flights of one radar, or spectrogram.n_fft set explicitly",
            )
    kw = {}
    if s.blade_tip_rev_s is not None:
        drones = [r for r in radars if r["blade_length_m"] is not None]
        if not drones:
            raise ConfigError(
                "config",
                "spectrogram.blade_tip_rev_s",
                f"is {s.blade_tip_rev_s} and {source} has no drone flight",
                "drone flights (blade_length_m) or doppler_span_hz/doppler_span_mps",
            )
        kw = dict(
            blade_length_m=max(r["blade_length_m"] for r in drones), body_mps=max(r["max_speed_mps"] for r in drones)
        )
    cfg = s.resolve(prf_hz, carrier_hz, **kw)
    d = describe(cfg, prf_hz, carrier_hz)
    log(
        f"spectrogram for {len(radars)} flights at PRF {prf_hz:g} Hz, carrier {carrier_hz / 1e9:g} GHz"
        + (f" (PRFs {prf.min():g}-{prf.max():g} Hz)" if np.ptp(prf) else "")
        + f": CPI {cfg.n_fft} pulses = {d['cpi_s']:.3f} s, {cfg.n_bins or cfg.n_fft} bins of {d['doppler_bin_hz']:.3f} Hz"
        + f" = {d['doppler_span_hz']:.1f} Hz = {d['doppler_span_mps']:.2f} m/s"
        + (
            f" (blade tips {kw['blade_length_m']:g} m at {s.blade_tip_rev_s:g} rev/s, body {kw['body_mps']:.1f} m/s:"
            f" ±{blade_tip_reach_hz(s.blade_tip_rev_s, kw['blade_length_m'], carrier_hz, kw['body_mps']):.1f} Hz)"
            if kw
            else ""
        )
    )
    return cfg


def spectrogram_for_flights(
    settings: SpectrogramSettings | dict | None, measured_dir, *, log=print
) -> SpectrogramConfig:
    """The config's ``spectrogram`` settings resolved for the flights in ``measured_dir``."""
    return resolve_for_flights(settings, flight_radars(measured_dir), source=measured_dir, log=log)
