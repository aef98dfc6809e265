"""Stage ``tile_spectrograms``: the paper's spectrograms cut into 20-timestep images.

``results/tiles/{dataset}.zarr`` holds ``images`` float32 [n, T, n_bins] (dB, T =
``tile_timesteps``) and, in the same folder, ``labels.csv`` (index, flight_id, set,
target, drone_model, radar_id, snr_db); ``snr_db`` is the image's mean body-line SNR
(the one SNR measure). A drone whose body sits in the clutter notch (hovering,
stand-mounted) has its SNR read on its strongest rotor line instead; where a store
holds such images, ``labels.csv`` has a column ``snr_line`` (``body`` or ``rotor``)
saying which line each image's SNR was measured on. ``real`` tiles every measured
flight of the split; a variant tiles the injected twins (labelled with their
measured flight's set).
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable, Iterator

import numpy as np
import pandas as pd

from ..errors import InputError
from ..io.flightzarr import Flight, read_flight
from ..spectra.snr import record_snr_db, snr_line
from ..spectra.spectrogram import SpectrogramConfig, spectrogram, tiles
from .injection import INJECTED_SCHEMA
from .lines import body_doppler_hz, finite_mean, measure_lines
from .stores import flight_ids, open_store, writing_store

TILES_SCHEMA = "tiles/1"
LABEL_COLUMNS = ["index", "flight_id", "set", "target", "drone_model", "radar_id", "snr_db"]


def tile_record(flight: Flight, iq: np.ndarray, spec_cfg: SpectrogramConfig, search_hz: float = 10.0):
    """Images of one record, each image's mean SNR and the line it is measured on.

    Returns
    -------
    images : ndarray, float32 [n_tiles, tile_timesteps, n_bins]
    snr_db : ndarray [n_tiles]
    snr_line : str
        ``body``, or ``rotor`` for a drone whose body sits in the clutter notch
        (:func:`microdoppler.spectra.snr.snr_line`).
    """
    if len(iq) < spec_cfg.n_fft:
        return np.empty((0, spec_cfg.tile_timesteps, spec_cfg.n_bins), np.float32), np.empty(0), "body"
    spec = spectrogram(iq, flight.prf_hz, spec_cfg)
    imgs = tiles(spec, spec_cfg.tile_timesteps).astype(np.float32)
    body = body_doppler_hz(flight.track_time_s, flight.track_radial_velocity_mps, flight.wavelength_m, spec.time_s)
    line = snr_line(flight.attrs.get("target", ""), body, highpass_hz=spec_cfg.highpass_hz, search_hz=search_hz)
    if line == "body":
        s = measure_lines(spec, body, None, search_hz=search_hz).body_db
    else:
        s = record_snr_db(spec, body, line, highpass_hz=spec_cfg.highpass_hz, search_hz=search_hz)
    T = spec_cfg.tile_timesteps
    snr = np.array([finite_mean(s[i * T : (i + 1) * T]) for i in range(len(imgs))])
    return imgs, snr, line


def measured_records(measured_dir, split: pd.DataFrame) -> Iterator[tuple[Flight, np.ndarray]]:
    """(flight, iq) of every measured flight in the split."""
    for fid in split.flight_id:
        fl = read_flight(Path(measured_dir) / f"{fid}.zarr")
        yield fl, fl.iq


def twin_records(measured_dir, injected_zarr, split: pd.DataFrame) -> Iterator[tuple[Flight, np.ndarray]]:
    """(measured flight, injected twin iq) of every twin whose flight is in the split."""
    root = open_store(injected_zarr, INJECTED_SCHEMA)
    keep = set(split.flight_id)
    for fid in flight_ids(root):
        if fid not in keep:
            continue
        fl = read_flight(Path(measured_dir) / f"{fid}.zarr")
        yield fl, np.asarray(root[fid]["iq"][...])


def build_tiles(
    records: Iterable[tuple[Flight, np.ndarray]],
    split: pd.DataFrame,
    out,
    *,
    dataset: str,
    spec_cfg: SpectrogramConfig,
    search_hz: float = 10.0,
    log=print,
) -> pd.DataFrame:
    """Write ``results/tiles/{dataset}.zarr`` (``images`` + ``labels.csv``)."""
    sets = split.set_index("flight_id")
    labels = []
    T, nb = spec_cfg.tile_timesteps, spec_cfg.n_bins
    with writing_store(
        out,
        {
            "schema": TILES_SCHEMA,
            "dataset": dataset,
            "unit": "dB",
            "spectrogram": {k: getattr(spec_cfg, k) for k in spec_cfg.__dataclass_fields__},
        },
    ) as root:
        z = root.create_array("images", shape=(0, T, nb), dtype=np.float32, chunks=(64, T, nb))
        for fl, iq in records:
            imgs, snr, line = tile_record(fl, iq, spec_cfg, search_hz)
            if imgs.shape[1:] != (T, nb):
                raise InputError(fl.flight_id, "spectrogram", f"gives images {imgs.shape[1:]}", f"({T}, {nb})")
            if len(imgs):
                z.append(imgs, axis=0)
            a = fl.attrs
            for s in snr:
                labels.append(
                    dict(
                        flight_id=fl.flight_id,
                        set=sets.loc[fl.flight_id, "set"],
                        target=a["target"],
                        drone_model=a.get("drone_model", ""),
                        radar_id=a["radar_id"],
                        snr_db=float(s),
                        snr_line=line,
                    )
                )
            log(
                f"{fl.flight_id}: {len(imgs)} images"
                + ("" if line == "body" else " (SNR on the rotor lines: body in the clutter notch)")
            )
        rotor = any(r["snr_line"] != "body" for r in labels)
        df = pd.DataFrame(labels, columns=LABEL_COLUMNS[1:] + (["snr_line"] if rotor else []))
        df.insert(0, "index", np.arange(len(df)))
        if z.shape[0] != len(df):
            raise InputError(out, "images", f"has {z.shape[0]} images", f"{len(df)} labels")
        root.attrs["n_images"] = len(df)
        df.to_csv(Path(root.store.root) / "labels.csv", index=False)
    return df


def read_tiles(path) -> tuple[np.ndarray, pd.DataFrame]:
    """``images`` float32 [n, T, n_bins] and the labels of a tiles store."""
    root = open_store(path, TILES_SCHEMA)
    labels = pd.read_csv(
        Path(path) / "labels.csv", dtype={"flight_id": str, "drone_model": str, "radar_id": str}, keep_default_na=False
    )
    images = np.asarray(root["images"][...])
    if images.shape[0] != len(labels):
        raise InputError(path, "labels.csv", f"has {len(labels)} rows", f"{images.shape[0]} (images)")
    return images, labels
