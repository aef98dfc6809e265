"""Tile sets for the classifier: images, labels, and the training-set recipe.

A tile store ``results/tiles/{dataset}.zarr`` holds ``images`` (float32
[n, 20, 480], dB) and ``labels.csv`` (index, flight_id, set, target,
drone_model, radar_id, snr_db). :func:`load_trainset` prefers
``microdoppler.datasets.load_trainset`` (issue 4) and falls back to a local
reading of the stores with the same recipe (workflow/README.md):

* ``real``: measured train and validation tiles;
* a variant: measured birds and Mini tiles plus the variant's Inspire and
  Matrice twins, in train and validation;
* test: always the measured test tiles.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError

LABEL_COLUMNS = ("index", "flight_id", "set", "target", "drone_model", "radar_id", "snr_db")
CLASSES = ("bird", "drone")  # class index 0 = bird, 1 = drone (the positive class)
LARGE_DRONES = ("inspire2", "matrice300")
SMALL_DRONES = ("mini2",)


@dataclass
class TileSet:
    """Images with their labels.

    Attributes
    ----------
    images : ndarray, float32 [n, n_timesteps, n_bins]
        Spectrogram tiles [dB].
    labels : DataFrame [n]
        One row per image (columns as in ``labels.csv``), aligned with ``images``.
    """

    images: np.ndarray
    labels: pd.DataFrame

    def __post_init__(self):
        if self.images.ndim != 3:
            raise InputError("TileSet", "images", f"has shape {self.images.shape}", "[n, n_timesteps, n_bins]")
        if len(self.images) != len(self.labels):
            raise InputError("TileSet", "labels", f"has {len(self.labels)} rows for {len(self.images)} images",
                             "one row per image")
        self.labels = self.labels.reset_index(drop=True)

    def __len__(self) -> int:
        return len(self.images)

    @property
    def y(self) -> np.ndarray:
        """Class index per image (0 = bird, 1 = drone), int64 [n]."""
        return (self.labels["target"].to_numpy() == "drone").astype(np.int64)

    def subset(self, mask) -> "TileSet":
        mask = np.asarray(mask)
        return TileSet(self.images[mask], self.labels[mask].reset_index(drop=True))

    @staticmethod
    def concat(parts) -> "TileSet":
        parts = list(parts)
        return TileSet(np.concatenate([p.images for p in parts]).astype(np.float32, copy=False),
                       pd.concat([p.labels for p in parts], ignore_index=True))


def as_tileset(obj) -> TileSet:
    """Coerce what ``microdoppler.datasets`` returns (TileSet-like or (images, labels))."""
    if isinstance(obj, TileSet):
        return obj
    if hasattr(obj, "images") and hasattr(obj, "labels"):
        return TileSet(np.asarray(obj.images, dtype=np.float32), pd.DataFrame(obj.labels))
    images, labels = obj
    return TileSet(np.asarray(images, dtype=np.float32), pd.DataFrame(labels))


def read_tiles(path) -> TileSet:
    """Read a tile store ``{dataset}.zarr`` (``images`` + ``labels.csv``)."""
    import zarr

    path = Path(path)
    if not (path / "labels.csv").exists():
        raise InputError(path, "labels.csv", "missing", "a tile store from tile_spectrograms")
    labels = pd.read_csv(path / "labels.csv", keep_default_na=False,
                         dtype={"flight_id": str, "drone_model": str, "radar_id": str})
    missing = [c for c in ("set", "target") if c not in labels.columns]
    if missing:
        raise InputError(path / "labels.csv", ",".join(missing), "missing column", ", ".join(LABEL_COLUMNS))
    bad = sorted(set(labels["target"]) - set(CLASSES))
    if bad:
        raise InputError(path / "labels.csv", "target", f"has values {bad}", "bird or drone")
    images = np.asarray(zarr.open_group(str(path), mode="r")["images"][:], dtype=np.float32)
    if images.ndim != 3 or len(images) != len(labels):
        raise InputError(path, "images", f"has shape {images.shape} for {len(labels)} labels",
                         "float32 [n, n_timesteps, n_bins], one per labels.csv row")
    if "index" in labels.columns:
        images = images[labels["index"].to_numpy()]
    return TileSet(images, labels)


def local_trainset(name: str, tiles_dir) -> tuple[TileSet, TileSet, TileSet]:
    """(train, validation, test) for training set ``name``, read from the tile stores."""
    tiles_dir = Path(tiles_dir)
    real = read_tiles(tiles_dir / "real.zarr")
    test = real.subset(real.labels["set"] == "test")
    if name == "real":
        keep = real
    else:
        twin = read_tiles(tiles_dir / f"{name}.zarr")
        large = real.labels["drone_model"].isin(LARGE_DRONES)
        keep = TileSet.concat([real.subset(~large.to_numpy()),
                               twin.subset(twin.labels["drone_model"].isin(LARGE_DRONES).to_numpy())])
    train = keep.subset(keep.labels["set"] == "train")
    val = keep.subset(keep.labels["set"] == "validation")
    for part, what in ((train, "train"), (val, "validation"), (test, "test")):
        if len(part) == 0:
            raise InputError(tiles_dir, f"{name}/{what}", "has no tiles", "at least one tile")
    return train, val, test


def load_trainset(name: str, tiles_dir) -> tuple[TileSet, TileSet, TileSet]:
    """(train, validation, test) for ``name``: ``microdoppler.datasets`` when built, else local."""
    try:
        from ..datasets import load_trainset as _load  # issue 4
    except ImportError:
        return local_trainset(name, tiles_dir)
    return tuple(as_tileset(p) for p in _load(name, tiles_dir))
