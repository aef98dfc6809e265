"""Stage ``inject_background`` (paper §V.A.3): a twin's target-only echo added to its
flight's ``background/iq``, the same resolution cells recorded with no target."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError
from ..flightzarr import read_flight
from .stores import flight_ids, open_store, put_array, writing_store

SYNTHETIC_SCHEMA = "twins/1"
INJECTED_SCHEMA = "injected/1"


def inject(target_iq: np.ndarray, background_iq: np.ndarray, source: str = "twin") -> np.ndarray:
    """Sum of the simulated target and the recorded background, complex64 [n_pulses]."""
    if background_iq is None:
        raise InputError(source, "background/iq", "missing", "a target-free recording of the flight's cells")
    if len(target_iq) != len(background_iq):
        raise InputError(source, "background/iq", f"has {len(background_iq)} pulses", f"{len(target_iq)} (the twin's)")
    return (np.asarray(target_iq, np.complex64) + np.asarray(background_iq, np.complex64)).astype(np.complex64)


def build_injected(measured_dir, synthetic_zarr, out, *, log=print) -> pd.DataFrame:
    """Write ``results/injected/{variant}.zarr``: group per twin with ``iq`` = twin + background."""
    syn = open_store(synthetic_zarr, SYNTHETIC_SCHEMA)
    rows = []
    with writing_store(out, {**dict(syn.attrs), "schema": INJECTED_SCHEMA}) as root:
        for fid in flight_ids(syn):
            g = syn[fid]
            flight = read_flight(f"{measured_dir}/{fid}.zarr")
            iq = inject(np.asarray(g["iq"][...]), flight.background_iq, f"{measured_dir}/{fid}.zarr")
            h = root.require_group(fid)
            h.attrs.update(dict(g.attrs))
            put_array(h, "iq", iq)
            rows.append(dict(flight_id=fid, n_pulses=len(iq)))
            log(f"{fid}: injected {len(iq)} pulses")
    return pd.DataFrame(rows, columns=["flight_id", "n_pulses"])
