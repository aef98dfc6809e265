"""Stage ``inject_background`` (paper §V.A.3): a twin's target-only echo added to its
flight's ``background/iq``, the same resolution cells recorded with no target."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..causes.twins import inject  # noqa: F401 (the twin plus its background; re-exported)
from ..io.flightzarr import read_flight
from .stores import flight_ids, open_store, put_array, writing_store

SYNTHETIC_SCHEMA = "twins/1"
INJECTED_SCHEMA = "injected/1"


def build_injected(measured_dir, synthetic_zarr, out, *, log=print) -> pd.DataFrame:
    """Write ``results/injected/{variant}.zarr``: group per twin with ``iq`` = twin + background."""
    syn = open_store(synthetic_zarr, SYNTHETIC_SCHEMA)
    rows = []
    with writing_store(out, {**dict(syn.attrs), "schema": INJECTED_SCHEMA}) as root:
        for fid in flight_ids(syn):
            g = syn[fid]
            flight = read_flight(f"{measured_dir}/{fid}.zarr")
            effects = dict(dict(g.attrs.get("extensions") or {}).get("effects") or {})
            iq = inject(
                np.asarray(g["iq"][...]),
                flight.background_iq,
                f"{measured_dir}/{fid}.zarr",
                effects=effects,
                prf_hz=flight.prf_hz,
                seed=int(g.attrs.get("twin_seed", 0)),
            )
            h = root.require_group(fid)
            h.attrs.update(dict(g.attrs))
            put_array(h, "iq", iq)
            rows.append(dict(flight_id=fid, n_pulses=len(iq)))
            log(f"{fid}: injected {len(iq)} pulses")
    return pd.DataFrame(rows, columns=["flight_id", "n_pulses"])
