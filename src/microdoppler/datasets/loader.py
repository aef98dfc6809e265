"""Training sets for the classifier (paper §V.B).

``real``: the measured train and validation tiles. A variant: the measured bird and
Mini tiles of train and validation plus the variant's twin tiles of the Inspire and
Matrice train and validation flights. Test is always the measured test tiles.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError
from .split import TWIN_MODELS, twin_model
from .tiles import read_tiles


@dataclass
class TileSet:
    """Images and labels of one part of a training set.

    Attributes
    ----------
    images : ndarray, float32 [n, T, n_bins] (dB)
    labels : ndarray, int64 [n]
        0 bird, 1 drone.
    table : DataFrame
        The tiles' rows of ``labels.csv`` (index, flight_id, set, target, ...) plus
        ``source`` (``real`` or the variant).
    """

    images: np.ndarray
    labels: np.ndarray
    table: pd.DataFrame

    def __len__(self) -> int:
        return len(self.labels)


def _part(images, table, mask, source) -> TileSet:
    t = table[mask].copy()
    t["source"] = source
    return TileSet(images[mask.to_numpy()], (t.target == "drone").to_numpy().astype(np.int64), t.reset_index(drop=True))


def _concat(a: TileSet, b: TileSet) -> TileSet:
    return TileSet(
        np.concatenate([a.images, b.images]),
        np.concatenate([a.labels, b.labels]),
        pd.concat([a.table, b.table], ignore_index=True),
    )


def load_trainset(name: str, tiles_dir="results/tiles") -> tuple[TileSet, TileSet, TileSet]:
    """(train, validation, test) of training set ``name`` (``real`` or a variant).

    Parameters
    ----------
    name : str
        ``real`` (the measured tiles) or a synthetic variant (``sub_cpi``, ...): the
        measured birds and Minis plus the variant's twins of the large drones.
    tiles_dir : path-like
        The folder of the tile stores (``real.zarr``, ``<variant>.zarr``).

    Returns
    -------
    train, validation, test : TileSet
        Images float32 [n, tile_timesteps, n_bins] [dB], labels int64 [n] (0 bird,
        1 drone) and their table. Test is always the measured test tiles.

    Raises
    ------
    microdoppler.errors.InputError
        When a tile store is missing or holds drones other than the twins' models.

    See Also
    --------
    split_flights, microdoppler.classifier.train

    Examples
    --------
    Tiles of six emulated 1 s flights (small STFT settings to stay fast):

    >>> import tempfile
    >>> from pathlib import Path
    >>> import pandas as pd
    >>> from microdoppler.datasets import load_trainset
    >>> from microdoppler.datasets.tiles import build_tiles
    >>> from microdoppler.emulator import FlightSpec, emulate_flight
    >>> from microdoppler.spectra import SpectrogramConfig
    >>> specs = [FlightSpec(f"d{i}", "drone", drone_model="inspire2", duration_s=1.0, seed=i) for i in range(3)]
    >>> specs += [FlightSpec(f"b{i}", "bird", bird_kind="single", duration_s=1.0, seed=10 + i) for i in range(3)]
    >>> flights = [emulate_flight(s)[0] for s in specs]
    >>> split = pd.DataFrame({"flight_id": [f.flight_id for f in flights],
    ...                       "set": ["train", "validation", "test"] * 2})
    >>> tiles_dir = Path(tempfile.mkdtemp())
    >>> cfg = SpectrogramConfig(n_fft=512, n_bins=64, tile_timesteps=4)
    >>> _ = build_tiles(((f, f.iq) for f in flights), split, tiles_dir / "real.zarr", dataset="real", spec_cfg=cfg,
    ...                 log=lambda message: None)
    >>> train, validation, test = load_trainset("real", tiles_dir)
    >>> train.images.shape, train.labels.tolist()
    ((12, 4, 64), [1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0])
    """
    tiles_dir = Path(tiles_dir)
    images, table = read_tiles(tiles_dir / "real.zarr")
    parts = {s: _part(images, table, table.set == s, "real") for s in ("train", "validation", "test")}
    if name == "real":
        return parts["train"], parts["validation"], parts["test"]
    path = tiles_dir / f"{name}.zarr"
    if not path.exists():
        raise InputError(path, "store", "does not exist", f"tiles of variant {name!r} (rule tile_spectrograms)")
    v_images, v_table = read_tiles(path)
    models = {str(m) for m in set(v_table.drone_model) if isinstance(m, str) and m}
    if not all(twin_model(m) for m in models):
        raise InputError(
            path, "labels.csv", f"has drone models {sorted(models)}", f"only {TWIN_MODELS} or drone models of your own"
        )
    # the measured flights of every twinned model are replaced by their twins
    twinned = set(TWIN_MODELS) | models
    out = []
    for s in ("train", "validation"):
        keep = (table.set == s) & ~table.drone_model.isin(twinned)
        out.append(_concat(_part(images, table, keep, "real"), _part(v_images, v_table, v_table.set == s, name)))
    return out[0], out[1], parts["test"]
