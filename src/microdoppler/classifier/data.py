"""Tile sets for the classifier: images, labels, and the training-set recipe.

A tile store ``results/tiles/{dataset}.zarr`` holds ``images`` (float32
[n, 20, 480], dB) and ``labels.csv`` (index, flight_id, set, target,
drone_model, radar_id, snr_db). :func:`load_trainset` reads them with
``microdoppler.datasets.load_trainset``'s recipe (workflow/README.md):

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
            raise InputError(
                "TileSet", "labels", f"has {len(self.labels)} rows for {len(self.images)} images", "one row per image"
            )
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
        return TileSet(
            np.concatenate([p.images for p in parts]).astype(np.float32, copy=False),
            pd.concat([p.labels for p in parts], ignore_index=True),
        )


def as_tileset(obj) -> TileSet:
    """Coerce what ``microdoppler.datasets`` returns (TileSet-like or (images, labels))."""
    if isinstance(obj, TileSet):
        return obj
    if hasattr(obj, "images") and hasattr(obj, "table"):  # microdoppler.datasets.TileSet
        return TileSet(np.asarray(obj.images, dtype=np.float32), pd.DataFrame(obj.table))
    if hasattr(obj, "images") and hasattr(obj, "labels"):
        return TileSet(np.asarray(obj.images, dtype=np.float32), pd.DataFrame(obj.labels))
    images, labels = obj
    return TileSet(np.asarray(images, dtype=np.float32), pd.DataFrame(labels))


def read_tiles(path) -> TileSet:
    """Read a tile store ``{dataset}.zarr`` (``images`` + ``labels.csv``) with
    :func:`microdoppler.datasets.tiles.read_tiles`, checking the class labels."""
    from ..datasets.tiles import read_tiles as _read

    images, labels = _read(path)
    missing = [c for c in ("set", "target") if c not in labels.columns]
    if missing:
        raise InputError(Path(path) / "labels.csv", ",".join(missing), "missing column", ", ".join(LABEL_COLUMNS))
    bad = sorted(set(labels["target"]) - set(CLASSES))
    if bad:
        raise InputError(Path(path) / "labels.csv", "target", f"has values {bad}", "bird or drone")
    if "index" in labels.columns:
        idx = labels["index"].to_numpy()
        if np.array_equal(np.sort(idx), np.arange(len(idx))):
            images = images[idx]  # rows of labels.csv may be in any order
    return TileSet(np.asarray(images, dtype=np.float32), labels)


def load_trainset(name: str, tiles_dir) -> tuple[TileSet, TileSet, TileSet]:
    """(train, validation, test) for ``name``: the recipe of
    :func:`microdoppler.datasets.load_trainset`, as classifier :class:`TileSet` s."""
    from ..datasets import load_trainset as _load

    parts = tuple(as_tileset(p) for p in _load(name, tiles_dir))
    for part, what in ((parts[0], "train"), (parts[2], "test")):  # validation may be empty (tiny worlds)
        if len(part) == 0:
            raise InputError(tiles_dir, f"{name}/{what}", "has no tiles", "at least one tile")
    return parts


def toy_tiles(
    n: int, *, seed: int, sets=("train",), n_timesteps: int = 20, n_bins: int = 480, flight_tiles: int = 4
) -> TileSet:
    """Toy dB tiles for tests and benchmarks (not physics; a stand-in for tile stores).

    Noise floor (exponential power, random level) plus a drifting body line; large
    drones add symmetric HERM-like lines at a random spacing, birds a wing-beat
    spread of the body line, Mini drones only the body line. Classes are balanced;
    ``flight_tiles`` consecutive tiles share a flight, set and radar.

    Returns
    -------
    TileSet with images float32 [n, n_timesteps, n_bins] and labels as ``labels.csv``.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(n_timesteps)[:, None]
    d = np.arange(n_bins)[None, :]
    images = np.empty((n, n_timesteps, n_bins), np.float32)
    rows = []
    models = ("inspire2", "matrice300", "mini2")
    for i in range(n):
        f = i // flight_tiles
        frng = np.random.default_rng([seed, f])
        target = "drone" if f % 2 else "bird"
        model = models[frng.integers(3)] if target == "drone" else ""
        floor = rng.exponential(1.0, (n_timesteps, n_bins)) * 10 ** (frng.uniform(-2, 1))
        b0 = rng.uniform(0.25, 0.75) * n_bins + rng.normal(0, 1.5, n_timesteps).cumsum()[:, None]
        snr = 10 ** (rng.uniform(1.0, 3.0))
        width = 1.5 + (rng.uniform(2, 6) * np.abs(np.sin(2 * np.pi * t / rng.uniform(2, 6))) if target == "bird" else 0)
        p = snr * np.exp(-0.5 * ((d - b0) / width) ** 2)
        if model in ("inspire2", "matrice300"):
            spacing = rng.uniform(15, 40) + rng.normal(0, 0.5, n_timesteps).cumsum()[:, None]
            for k in range(1, 6):
                amp = snr * 10 ** (-1.5 - 0.3 * k) * rng.uniform(0.3, 1.0)
                p = p + amp * (
                    np.exp(-0.5 * ((d - b0 - k * spacing) / 1.5) ** 2)
                    + np.exp(-0.5 * ((d - b0 + k * spacing) / 1.5) ** 2)
                )
        images[i] = 10 * np.log10(floor + p)
        rows.append(
            dict(
                index=i,
                flight_id=f"toy{f:04d}",
                set=sets[f % len(sets)],
                target=target,
                drone_model=model,
                radar_id=f"radar{1 + f % 2}",
                snr_db=10 * np.log10(snr),
            )
        )
    return TileSet(images, pd.DataFrame(rows))


def write_tiles(path, tiles: TileSet) -> Path:
    """Write a ``tiles/1`` store (``images`` + ``labels.csv``) atomically (tests, benchmarks)."""
    import shutil

    import zarr

    from ..io.outputs import atomic_dir, commit_dir

    path = Path(path)
    tmp = atomic_dir(path)
    try:
        g = zarr.open_group(str(tmp), mode="w", zarr_format=3)
        g.create_array("images", data=tiles.images.astype(np.float32), chunks=(256,) + tiles.images.shape[1:])
        g.attrs.update({"schema": "tiles/1", "unit": "dB", "n_images": len(tiles)})
        tiles.labels.to_csv(tmp / "labels.csv", index=False)
        commit_dir(tmp, path)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return path
