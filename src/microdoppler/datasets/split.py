"""Flight-disjoint train/test/validation split balanced by class (paper §III.C).

The paper counts the 20-timestep images of every flight and forms train, test and
validation subsets in a 60:30:10 ratio *of images*, at random, never splitting a
flight. Here each class (bird, inspire2, matrice300, mini2) is split on its own:
``n_trials`` seeded random orders of its flights are each dealt greedily to the set
furthest below its target share of images, and the order with the smallest largest
deviation from the target shares wins (ties: more sets non-empty). Same seed, same
split.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError
from ..spectra.spectrogram import SpectrogramConfig

SETS = ("train", "test", "validation")
#: paper §III.C: 60:30:10 train:test:validation
PAPER_FRACTIONS = {"train": 0.6, "test": 0.3, "validation": 0.1}
CLASSES = ("bird", "inspire2", "matrice300", "mini2")
#: drone models replaced by synthetic twins in the variant training sets
TWIN_MODELS = ("inspire2", "matrice300")


def twin_model(drone_model) -> bool:
    """Whether the flights of ``drone_model`` get synthetic twins: the paper's
    :data:`TWIN_MODELS`, and a model the catalog
    (:data:`microdoppler.synthesis.radar.DRONE_MODELS`) does not hold, a drone of your
    own whose rotor lines the calibration measures. The catalog's Mini 2 (0.06 m
    blades, lines below the noise at L band) gets none, as in the paper."""
    from ..synthesis.radar import DRONE_MODELS

    model = "" if drone_model is None else str(drone_model)
    return model in TWIN_MODELS or (model != "" and model not in DRONE_MODELS)


def flight_class(target: str, drone_model: str | None) -> str | None:
    """Class of a flight: ``bird``, the drone model, or None (a target-free recording)."""
    if target == "bird":
        return "bird"
    if target == "drone":
        return str(drone_model)
    return None


def n_timesteps(n_pulses: int, cfg: SpectrogramConfig) -> int:
    """STFT timesteps of a record of ``n_pulses`` (windows wholly inside the record)."""
    return 0 if n_pulses < cfg.n_fft else 1 + (n_pulses - cfg.n_fft) // cfg.hop


def n_images(n_pulses: int, cfg: SpectrogramConfig) -> int:
    """Non-overlapping ``tile_timesteps`` images of a record of ``n_pulses``."""
    return n_timesteps(n_pulses, cfg) // cfg.tile_timesteps


def _deal(weights: np.ndarray, order: np.ndarray, fractions: np.ndarray) -> np.ndarray:
    total = max(weights.sum(), 1e-9)
    have = np.zeros(len(fractions))
    out = np.empty(len(weights), np.int64)
    counts = np.zeros(len(fractions))
    for i in order:
        # deficit in images; flights without images are dealt by flight counts
        deficit = fractions * total - have if weights[i] > 0 else fractions * len(weights) - counts
        j = int(np.argmax(deficit))
        out[i] = j
        have[j] += weights[i]
        counts[j] += 1
    return out


def split_class(images: np.ndarray, *, seed: int, fractions=(0.6, 0.3, 0.1), n_trials: int = 500) -> np.ndarray:
    """Set index (0 train, 1 test, 2 validation) of each flight of one class.

    Parameters
    ----------
    images : ndarray, int [n_flights]
        Images per flight.
    seed : int
    fractions : sequence of 3 floats
        Target shares of images; must sum to 1.
    n_trials : int
        Random orders tried.
    """
    fr = np.asarray(fractions, float)
    if fr.shape != (3,) or np.any(fr < 0) or abs(fr.sum() - 1) > 1e-6:
        raise ValueError(f"fractions={tuple(fractions)} must be 3 non-negative shares summing to 1")
    w = np.asarray(images, float)
    n = len(w)
    if n == 0:
        return np.empty(0, np.int64)
    rng = np.random.default_rng(seed)
    best, best_key = None, None
    want_sets = min(n, int(np.sum(fr > 0)))
    for _ in range(max(1, n_trials)):
        a = _deal(w, rng.permutation(n), fr)
        share = np.bincount(a, weights=w, minlength=3) / max(w.sum(), 1e-9)
        key = (want_sets - len(np.unique(a)), float(np.max(np.abs(share - fr))))
        if best_key is None or key < best_key:
            best, best_key = a, key
    return best


def split_flights(
    flights: pd.DataFrame, *, seed: int, fractions: dict | None = None, n_trials: int = 500
) -> pd.DataFrame:
    """Assign every flight to a set, per class.

    Parameters
    ----------
    flights : DataFrame
        Columns flight_id, target, drone_model, radar_id, images. Flights whose class is
        None (target ``none``) are left out.
    seed : int
        Seed of the random assignments (same seed, same split).
    fractions : dict, optional
        ``{set: fraction}`` of images for ``train``, ``validation`` and ``test``
        (default the paper's 60:30:10).
    n_trials : int
        Random assignments tried per class; the one nearest the fractions is kept.

    Returns
    -------
    DataFrame
        Columns flight_id, set, target, drone_model, radar_id, class, images; one
        row per flight, sorted by flight_id. No flight is split across sets.

    Raises
    ------
    microdoppler.errors.InputError
        When a flight id appears twice.

    Examples
    --------
    >>> import pandas as pd
    >>> from microdoppler.datasets import split_flights
    >>> flights = pd.DataFrame({"flight_id": [f"f{i}" for i in range(10)],
    ...                         "target": ["drone"] * 5 + ["bird"] * 5,
    ...                         "drone_model": ["inspire2"] * 5 + [None] * 5, "radar_id": "radar1",
    ...                         "images": [3, 5, 2, 4, 6, 1, 2, 3, 4, 5]})
    >>> split = split_flights(flights, seed=0)
    >>> split.loc[split["class"] == "bird", "set"].value_counts().sort_index().to_dict()
    {'test': 2, 'train': 2, 'validation': 1}
    >>> split.loc[split["class"] == "inspire2", "set"].value_counts().sort_index().to_dict()
    {'test': 1, 'train': 3, 'validation': 1}
    """
    fractions = fractions or PAPER_FRACTIONS
    fr = [float(fractions[s]) for s in SETS]
    df = flights.copy()
    df["drone_model"] = df["drone_model"].fillna("").astype(str)
    df["class"] = [flight_class(t, m) for t, m in zip(df.target, df.drone_model)]
    df = df[df["class"].notna()].sort_values("flight_id").reset_index(drop=True)
    if df.flight_id.duplicated().any():
        raise InputError(
            "flights", "flight_id", f"{df.flight_id[df.flight_id.duplicated()].iloc[0]!r} twice", "unique ids"
        )
    df["set"] = ""
    for ci, (cls, part) in enumerate(sorted(df.groupby("class"), key=lambda kv: kv[0])):
        a = split_class(part.images.to_numpy(), seed=seed + 7919 * ci, fractions=fr, n_trials=n_trials)
        df.loc[part.index, "set"] = [SETS[i] for i in a]
    return df[["flight_id", "set", "target", "drone_model", "radar_id", "class", "images"]]


def read_split(path) -> pd.DataFrame:
    """Read ``results/splits/flights.csv`` (flight_id, set, target, drone_model, radar_id)."""
    path = Path(path)
    if not path.exists():
        raise InputError(path, "file", "does not exist", "the split table of split_flights")
    df = pd.read_csv(path, dtype={"flight_id": str, "drone_model": str, "radar_id": str}, keep_default_na=False)
    for c in ("flight_id", "set", "target", "drone_model", "radar_id"):
        if c not in df.columns:
            raise InputError(path, c, "column missing", "flight_id, set, target, drone_model, radar_id")
    bad = set(df.set) - set(SETS)
    if bad:
        raise InputError(path, "set", f"has {sorted(bad)}", " or ".join(SETS))
    return df
