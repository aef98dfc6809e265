"""Predictions of a trained classifier on the measured test tiles."""

from __future__ import annotations

import numpy as np
import pandas as pd
import torch

from .data import CLASSES, TileSet
from .models import Normalisation

PREDICTION_COLUMNS = ("index", "flight_id", "target", "drone_model", "radar_id", "snr_db", "predicted", "p_drone")


@torch.no_grad()
def predict(
    model: torch.nn.Module, images_db: np.ndarray, normalisation: Normalisation, batch_size: int = 256
) -> np.ndarray:
    """Drone probability per image.

    Parameters
    ----------
    model : torch.nn.Module
        A classifier (:func:`build_model`, ``train(...).model``).
    images_db : ndarray, float32 [n, T, D]
        Tiles in dB.
    normalisation : Normalisation
        The normalisation the model was trained with (``TrainConfig.normalisation``).
    batch_size : int
        Images per forward pass.

    Returns
    -------
    p_drone : ndarray, float64 [n]
        Probability of the drone class per image, in [0, 1].

    See Also
    --------
    train

    Examples
    --------
    >>> import numpy as np
    >>> import torch
    >>> from microdoppler.classifier import Normalisation, build_model, predict
    >>> _ = torch.manual_seed(0)
    >>> model = build_model("compact", compact={"doppler_pool": 4})
    >>> p = predict(model, np.zeros((3, 8, 64), np.float32), Normalisation())
    >>> p.shape, p.dtype, bool(((p >= 0) & (p <= 1)).all())
    ((3,), dtype('float64'), True)
    """
    model.eval()
    x = torch.from_numpy(normalisation(images_db))
    out = [torch.softmax(model(x[i : i + batch_size]), dim=1)[:, 1] for i in range(0, len(x), batch_size)]
    return torch.cat(out).double().numpy() if out else np.zeros(0)


def predictions_table(test: TileSet, p_drone: np.ndarray) -> pd.DataFrame:
    """One row per test tile: its labels, ``predicted`` class (bird/drone) and ``p_drone``."""
    df = test.labels.copy()
    if "index" not in df.columns:
        df["index"] = np.arange(len(df))
    for c in ("flight_id", "drone_model", "radar_id"):
        if c not in df.columns:
            df[c] = ""
    if "snr_db" not in df.columns:
        df["snr_db"] = np.nan
    df["predicted"] = np.where(np.asarray(p_drone) >= 0.5, CLASSES[1], CLASSES[0])
    df["p_drone"] = np.asarray(p_drone)
    return df[list(PREDICTION_COLUMNS)]
