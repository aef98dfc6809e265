"""Bird/drone classifier: models, training over seeds, evaluation and the paper's reports (§IV, §V.C)."""

from .augment import Augmentation
from .data import CLASSES, TileSet, load_trainset, read_tiles
from .evaluation import predict, predictions_table
from .metrics import class_metrics, confusion_matrix, seed_metrics
from .models import AlexNet, CompactCNN, Normalisation, build_model
from .training import TrainConfig, TrainResult, best_epoch, load_model, save_model, stop_epoch, train

__all__ = [
    "Augmentation",
    "CLASSES",
    "TileSet",
    "load_trainset",
    "read_tiles",
    "predict",
    "predictions_table",
    "class_metrics",
    "confusion_matrix",
    "seed_metrics",
    "AlexNet",
    "CompactCNN",
    "Normalisation",
    "build_model",
    "TrainConfig",
    "TrainResult",
    "best_epoch",
    "load_model",
    "save_model",
    "stop_epoch",
    "train",
]
