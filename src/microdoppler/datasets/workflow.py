"""Glue for the pipeline scripts: whole-stage functions that take paths."""

from __future__ import annotations

import pandas as pd

from ..io.flightzarr import read_flight
from ..io.inventory import list_flights
from ..spectra.spectrogram import SpectrogramConfig
from .split import PAPER_FRACTIONS, flight_class, split_flights
from .tables import flight_snr_row, table_iii


def split_and_table_iii(
    measured_dir,
    *,
    spec_cfg: SpectrogramConfig,
    search_hz: float = 10.0,
    seed: int = 0,
    fractions: dict | None = None,
    n_trials: int = 500,
    log=print,
):
    """Split the measured flights and build Table III.

    Returns
    -------
    split : DataFrame (flight_id, set, target, drone_model, radar_id, class, images; and
        ``snr_line`` when some flight's SNR is measured on its rotor lines)
    table : DataFrame (see :func:`tables.table_iii`)
    """
    flights = list_flights(measured_dir)
    rows, snr, line = [], {}, {}
    for fl in flights.itertuples():
        if flight_class(fl.target, fl.drone_model) is None:
            log(f"{fl.flight_id}: target {fl.target!r}: not a class, left out of the split")
            continue
        d = flight_snr_row(read_flight(fl.path), spec_cfg=spec_cfg, search_hz=search_hz)
        snr[fl.flight_id] = d.pop("snr_db")
        line[fl.flight_id] = d.pop("snr_line")
        rows.append(
            dict(flight_id=fl.flight_id, target=fl.target, drone_model=fl.drone_model, radar_id=fl.radar_id, **d)
        )
        what = "body SNR" if line[fl.flight_id] == "body" else "rotor-line SNR (body in the clutter notch)"
        log(f"{fl.flight_id}: {d['images']} images, {what} {d['snr_mean_db']:.1f} +/- {d['snr_std_db']:.1f} dB")
    split = split_flights(pd.DataFrame(rows), seed=seed, fractions=fractions or PAPER_FRACTIONS, n_trials=n_trials)
    if any(v != "body" for v in line.values()):
        split["snr_line"] = [line[f] for f in split.flight_id]
    return split, table_iii(split, snr, line)


def load_extensions(path):
    """The diagnosis' model extensions, or None without a path: ``extensions/2`` ->
    per-twin :class:`~.extended.TwinExtensions`, ``extensions/1`` -> one
    :class:`~microdoppler.causes.extensions.ExtensionSet` for every twin.

    Imported lazily: only the ``extended`` variant needs those modules.
    """
    if not path:
        return None
    from .extended import load_twin_extensions

    return load_twin_extensions(path)
