"""Figures of merit of a bird/drone classifier (paper §V.C, Table V).

Definitions (positive class = the class named):

* accuracy = correct / all;
* recall of class c = TP / (TP + FN) = correct among the true c;
* precision of class c = TP / (TP + FP) = correct among the predicted c.

The paper defines recall as TP/(TP+FN) but then explains it with the words of
precision ("90 % of predicted drones were truthfully drones"). Both are
reported here, each correctly defined. Large-drone accuracy (Inspire 2,
Matrice 300) and small-drone accuracy (Mini 2) are the recalls of the drone
class restricted to those models (§IV's "sub-drone class rate of false alarm"
is this accuracy: 94 % for large drones in Table V).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError
from .data import CLASSES, LARGE_DRONES, SMALL_DRONES


def confusion_matrix(true, predicted, classes=CLASSES) -> np.ndarray:
    """Counts int64 [n_classes, n_classes]: rows = true class, columns = predicted class."""
    true, predicted = np.asarray(true), np.asarray(predicted)
    if true.shape != predicted.shape:
        raise InputError("predictions", "predicted", f"has shape {predicted.shape}", f"shape {true.shape}")
    index = {c: i for i, c in enumerate(classes)}
    cm = np.zeros((len(classes), len(classes)), dtype=np.int64)
    for t, p in zip(true, predicted):
        if t not in index or p not in index:
            raise InputError("predictions", "target/predicted", f"has value {t!r}/{p!r}", f"one of {classes}")
        cm[index[t], index[p]] += 1
    return cm


def _ratio(num, den) -> float:
    return float(num) / float(den) if den else float("nan")


def class_metrics(cm: np.ndarray, classes=CLASSES) -> dict:
    """Accuracy and per-class recall and precision from a confusion matrix (rows = true)."""
    cm = np.asarray(cm, dtype=float)
    out = {"accuracy": _ratio(np.trace(cm), cm.sum())}
    for i, c in enumerate(classes):
        out[f"{c}_recall"] = _ratio(cm[i, i], cm[i, :].sum())
        out[f"{c}_precision"] = _ratio(cm[i, i], cm[:, i].sum())
    return out


def seed_metrics(pred: pd.DataFrame) -> dict:
    """All figures of merit of one run's predictions (``evaluation.predictions_table``).

    Returns accuracy, {bird,drone}_{recall,precision}, large_drone_accuracy,
    small_drone_accuracy, n_test and accuracy_radar_<id> per radar (fractions in [0, 1]).
    """
    for c in ("target", "predicted", "drone_model", "radar_id"):
        if c not in pred.columns:
            raise InputError("predictions", c, "missing column", "target, predicted, drone_model, radar_id")
    out = class_metrics(confusion_matrix(pred["target"], pred["predicted"]))
    correct = (pred["target"] == pred["predicted"]).to_numpy()
    model = pred["drone_model"].astype(str)
    for name, models in (("large_drone_accuracy", LARGE_DRONES), ("small_drone_accuracy", SMALL_DRONES)):
        m = (pred["target"] == "drone").to_numpy() & model.isin(models).to_numpy()
        out[name] = float(correct[m].mean()) if m.any() else float("nan")
    out["n_test"] = int(len(pred))
    for radar, g in pred.groupby(pred["radar_id"].astype(str), sort=True):
        out[f"accuracy_radar_{radar}"] = float((g["target"] == g["predicted"]).mean())
    return out
