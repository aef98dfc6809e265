"""Training procedure (paper §IV) with a deterministic, seeded implementation.

SGD with momentum and L2 (weight decay), step learning-rate decay, mini-batches
reshuffled every epoch. After every epoch the model is evaluated on the training
and validation sets. Training stops once the validation loss has exceeded the
training loss ``exceed_limit`` times (or at ``max_epochs``); the kept model is the
one of the epoch with the largest sum of training and validation accuracy (paper), or
with ``average_last_epochs`` K > 0 the average of the last K epochs' weights.
"""

from __future__ import annotations

import copy
import logging
import time
from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd
import torch
from torch.nn import functional as F

from ..configfields import check_keys, check_ranges, config_names, fields_schema, knob
from ..errors import InputError
from .augment import Augmentation
from .data import TileSet
from .models import CompactSettings, Normalisation, build_model

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ClassifierRuns:
    """The classifier keys the workflow reads (which runs); the rest are
    :class:`~microdoppler.classifier.training.TrainConfig`'s."""

    trainsets: list[str] = knob(
        description="Training sets: 'real' and/or variant names. Empty: real plus every variant of sampling.variants "
        "(including 'extended' when built).",
        default_factory=list,
    )
    seeds: list[int] = knob(
        description="Random seeds; one training run per training set and seed (paper: 9). A seed fixes "
        "initialisation, dropout and shuffling: the same seed gives identical metrics.",
        default_factory=lambda: [1, 2, 3, 4, 5, 6, 7, 8, 9],
    )
    threads: int = knob(
        1,
        "torch threads per training job (results are reproducible for a given value). 1 lets 2 jobs run side by "
        "side on 2 cores.",
        minimum=1,
    )


#: keys of the config's ``classifier:`` section that the workflow reads, not training
WORKFLOW_KEYS = frozenset(config_names(ClassifierRuns))
#: the keys of ``classifier.compact`` (``CompactCNN``'s keyword arguments)
COMPACT_KEYS = tuple(config_names(CompactSettings))


@dataclass(frozen=True)
class TrainConfig:
    """Classifier and training settings (config ``classifier:``; see the schema).

    Parameters
    ----------
    architecture : {'compact', 'alexnet'}
    compact : dict
        CompactCNN keyword arguments (channels, doppler_pool, dropout).
    alexnet_weights : str
        Local torchvision AlexNet state_dict; empty trains AlexNet from scratch.
    colormap : str
        AlexNet false-colour map.
    learning_rate : float
        Initial learning rate (paper 1.5e-4 for pretrained AlexNet).
    momentum : float
        SGD momentum (paper 0.98).
    weight_decay : float
        L2 regularisation (paper 2e-4).
    batch_size : int
        Mini-batch size (paper 16).
    lr_step_epochs : int
        Epochs between learning-rate decays (paper 10).
    lr_gamma : float
        Decay factor (paper 0.1).
    max_epochs : int
        Epoch cap (time budget).
    exceed_limit : int
        Stop after the validation loss exceeded the training loss this many times (paper 10).
    reevaluate_train : bool
        Evaluate the end-of-epoch model on the whole training set (paper); False uses
        the running mini-batch loss and accuracy of the epoch (cheaper).
    average_last_epochs : int
        0 (paper): keep the epoch with the largest train + validation accuracy. K > 0:
        keep the average of the weights after each of the last K epochs run (stochastic
        weight averaging within one seed's run; no ensembling across seeds), which
        does not depend on a small validation set's noisy accuracy.
    normalisation : Normalisation
        Per-tile normalisation of the dB images (clip relative to the tile median).
    augment : Augmentation
        Doppler-axis augmentation of training tiles (default: none).

    Raises
    ------
    microdoppler.errors.ConfigError
        When a setting is out of its range.

    See Also
    --------
    train

    Examples
    --------
    >>> from microdoppler.classifier import TrainConfig
    >>> cfg = TrainConfig.from_config({"max_epochs": 3, "batch_size": 8})
    >>> cfg.architecture, cfg.max_epochs, cfg.batch_size
    ('compact', 3, 8)
    """

    architecture: str = knob(
        "compact",
        "'compact': small CNN for 20x480 dB tiles, trained from scratch (default; ~3.5k parameters, hundreds of "
        "images/s on one core). 'alexnet': the paper's AlexNet on 224x224 colour-mapped tiles (about 30 images/s on "
        "2 cores from scratch: for GPUs or with pretrained weights).",
        enum=["compact", "alexnet"],
    )
    compact: dict = knob(
        description="Compact CNN: channels of the conv blocks, doppler_pool (pooling factor along Doppler after the "
        "first block), dropout before the last layer.",
        default_factory=dict,
        schema={"properties": fields_schema(CompactSettings), "additionalProperties": False},
    )
    alexnet_weights: str = knob(
        "",
        "Local path of a torchvision AlexNet ImageNet state_dict (e.g. alexnet-owt-7be5be79.pth). When set "
        "(architecture alexnet), the conv layers are loaded and frozen and only the fully connected layers are "
        "trained, as in the paper. Empty: AlexNet is trained from scratch.",
    )
    colormap: str = knob(
        "jet",
        "Matplotlib colour map turning a normalised tile into the RGB image AlexNet takes (the paper used an RGB "
        "false-colour map).",
    )
    learning_rate: float = knob(
        0.01,
        "Initial SGD learning rate. Paper 1.5e-4 (fine-tuning pretrained AlexNet FC layers); a from-scratch compact "
        "CNN at that rate barely learns within the epoch cap (toy tiles: 64 % train accuracy after 15 epochs, "
        "against 100 % by epoch 10 at 5e-3 to 1e-2), so the default is 1e-2.",
        exclusive_minimum=0,
    )
    momentum: float = knob(
        0.9,
        "SGD momentum. Paper 0.98 (with lr 1.5e-4). With a from-scratch learning rate, 0.98 (effective step "
        "lr/(1-m) = 50 lr) gave divergence spikes (toy tiles, lr 5e-3: training loss 0.17 -> 1.23 in one epoch, "
        "accuracy back to chance), so the default is 0.9.",
        minimum=0,
        exclusive_maximum=1,
    )
    weight_decay: float = knob(2e-4, "L2 regularisation (SGD weight decay), as in the paper.", minimum=0)
    batch_size: int = knob(16, "Mini-batch size, as in the paper; reshuffled every epoch with the seed.", minimum=1)
    lr_step_epochs: int = knob(
        10,
        "Epochs between learning-rate decays (paper: 10). Default 10 with max_epochs 12; config/paper.yaml uses 6 "
        'with max_epochs 9 (docs/experiments.md, "Classifier training").',
        minimum=1,
    )
    lr_gamma: float = knob(0.1, "Learning-rate decay factor, as in the paper.", exclusive_minimum=0, maximum=1)
    max_epochs: int = knob(
        12,
        "Epoch cap (the paper has none: it stops on exceed_limit alone, which a from-scratch model with a cap "
        "rarely reaches). Default 12. config/paper.yaml uses 9 (with lr_step_epochs 6, average_last_epochs 4) so "
        "that the paper profile's 54 runs fit about an hour on 2 cores (docs/experiments.md, \"Classifier "
        'training"); on the default world (~420 training tiles) fewer epochs undertrain, so the default stays 12.',
        minimum=1,
    )
    exceed_limit: int = knob(
        10,
        "Stop after the validation loss has exceeded the training loss this many epochs (paper: 10). The kept model "
        "is the epoch with the largest training + validation accuracy.",
        minimum=1,
    )
    reevaluate_train: bool = knob(
        False,
        "true: evaluate each epoch's model on the whole training set, as the paper did. false (default): use the "
        "epoch's running mini-batch loss and accuracy (what MATLAB prints as mini-batch accuracy), which saves "
        "about a third of each epoch and keeps 45 runs of the default profile within ~7 minutes on 2 cores; the "
        "validation set is always evaluated at the end of every epoch.",
    )
    average_last_epochs: int = knob(
        0,
        "0 (paper): keep the epoch with the largest training + validation accuracy. K > 0 (default 4 of 12 epochs; "
        "config/paper.yaml 4 of 9): keep the average of the weights after each of the last K epochs of the run "
        "(stochastic weight averaging within one seed's run; nothing is averaged across seeds). On the default "
        "world it halves the seed-to-seed std of the real-trained accuracy (12.5 -> 6.1 points, "
        "docs/experiments.md), because the kept model no longer depends on a small validation set's noisy accuracy.",
        minimum=0,
    )
    normalisation: Normalisation = knob(
        Normalisation(),
        "Per-image normalisation: subtract the tile's median (its noise/clutter floor: tiles are uncalibrated dB "
        "whose level moves with range and radar gain), divide by scale_db, clip to [low_db, high_db] relative to "
        "the median (values far below the floor are noise; the upper limit bounds the dynamic range like a colour "
        "map's limits).",
    )
    augment: Augmentation = knob(
        Augmentation(),
        "Doppler-axis augmentation of training tiles (microdoppler.classifier.augment; never of validation or test "
        "tiles). Each training tile is, with `probability` per epoch, rescaled about zero Doppler by a factor drawn "
        "in [1 - doppler_stretch, 1 + doppler_stretch] (every line moves as with rotors and body that much faster "
        "or slower) blurred along Doppler by a Gaussian of standard deviation drawn in [0, doppler_blur_bins] bins "
        "(lines smeared as by rotor speeds changing within a CPI), rescaled by a factor that varies sinusoidally "
        "over the tile's timesteps with amplitude drawn in [0, doppler_wander] (lines that wander as measured rotor "
        "lines do). Draws come from the run's seed. Default: off (the paper used none).",
    )

    def __post_init__(self):
        check_ranges(self, "classifier")  # the knobs' ranges, as the schema has them

    @classmethod
    def from_config(cls, cfg: dict | None, source="config") -> "TrainConfig":
        """From the config's ``classifier:`` mapping; the workflow's own keys
        (``ClassifierRuns``) are left to it. A key that is neither, here or in
        ``compact``, ``normalisation`` or ``augment``, is a one-line
        ``microdoppler.errors.ConfigError`` naming it and its section
        (``<source>: classifier.<key>: unknown key in section classifier (expected
        one of: ...)``)."""
        cfg = check_keys(cfg, [*config_names(ClassifierRuns), *config_names(cls)], "classifier", source)
        cfg = {k: v for k, v in cfg.items() if k not in WORKFLOW_KEYS}
        compact = check_keys(cfg.pop("compact", None), COMPACT_KEYS, "classifier.compact", source)
        norm = check_keys(
            cfg.pop("normalisation", None), config_names(Normalisation), "classifier.normalisation", source
        )
        aug = check_keys(cfg.pop("augment", None), config_names(Augmentation), "classifier.augment", source)
        return cls(compact=compact, normalisation=Normalisation(**norm), augment=Augmentation(**aug), **cfg)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["normalisation"] = asdict(self.normalisation)
        d["augment"] = asdict(self.augment)
        return d


def setup_determinism(seed: int, threads: int = 1) -> torch.Generator:
    """Seed torch, force deterministic kernels, set the thread count; return a shuffling generator."""
    torch.set_num_threads(max(1, int(threads)))
    torch.use_deterministic_algorithms(True)
    torch.manual_seed(seed)
    return torch.Generator().manual_seed(seed)


def stop_epoch(val_loss, train_loss, exceed_limit: int) -> int | None:
    """Epoch (0-based) at which training stops: the ``exceed_limit``-th epoch whose
    validation loss exceeds its training loss; None if that never happens."""
    exceed = np.cumsum(np.asarray(val_loss) > np.asarray(train_loss))
    hit = np.flatnonzero(exceed >= exceed_limit)
    return int(hit[0]) if len(hit) else None


def best_epoch(train_accuracy, val_accuracy) -> int:
    """Epoch (0-based) with the largest train + validation accuracy (first one on ties)."""
    total = np.asarray(train_accuracy, float) + np.nan_to_num(np.asarray(val_accuracy, float), nan=0.0)
    return int(np.argmax(total))


# Forward pass of evaluation in chunks of this many images: the compact CNN's first feature
# map of 256 images (59 MB) does not stay in cache, 32 do, and the per-image logits are
# the same bits (the timing: docs/experiments.md).
EVAL_FORWARD_BATCH = 32


@torch.no_grad()
def _evaluate(model, x: torch.Tensor, y: torch.Tensor, batch_size: int) -> tuple[float, float]:
    """(mean cross-entropy loss, accuracy) of ``model`` on normalised ``x``; NaN when empty.

    The loss is summed over blocks of ``batch_size`` images, whose logits are computed
    in chunks of :data:`EVAL_FORWARD_BATCH` (same logits, less memory traffic)."""
    if len(x) == 0:
        return float("nan"), float("nan")
    model.eval()
    loss, correct = 0.0, 0
    for i in range(0, len(x), batch_size):
        block = x[i : i + batch_size]
        logits = torch.cat([model(block[j : j + EVAL_FORWARD_BATCH]) for j in range(0, len(block), EVAL_FORWARD_BATCH)])
        loss += F.cross_entropy(logits, y[i : i + batch_size], reduction="sum").item()
        correct += (logits.argmax(1) == y[i : i + batch_size]).sum().item()
    return loss / len(x), correct / len(x)


def train_epoch(
    model,
    opt,
    gen: torch.Generator,
    xt: torch.Tensor,
    yt: torch.Tensor,
    batch_size: int,
    augment: Augmentation | None = None,
) -> tuple[float, float]:
    """One epoch of SGD over ``xt`` in an order drawn from ``gen`` (mini-batches
    augmented by ``augment`` with draws from ``gen``); returns the running (mean
    mini-batch loss, accuracy) of the epoch."""
    model.train()
    order = torch.randperm(len(xt), generator=gen)
    run_loss, run_correct = 0.0, 0
    for i in range(0, len(xt), batch_size):
        idx = order[i : i + batch_size]
        xb = augment(xt[idx], gen) if augment is not None else xt[idx]  # inactive: returned as is, no draws
        logits = model(xb)
        loss = F.cross_entropy(logits, yt[idx])
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        run_loss += loss.item() * len(idx)
        run_correct += (logits.argmax(1) == yt[idx]).sum().item()
    return run_loss / len(xt), run_correct / len(xt)


@dataclass
class TrainResult:
    """A trained classifier.

    Attributes
    ----------
    model : torch.nn.Module
        The model of the best epoch, in eval mode.
    history : DataFrame
        One row per epoch: epoch (1-based), learning_rate, train_loss, train_accuracy,
        val_loss, val_accuracy, val_exceeds_train, selected, seconds.
    best_epoch : int
        1-based epoch of the kept model.
    """

    model: torch.nn.Module
    history: pd.DataFrame
    best_epoch: int


def train(
    train_set: TileSet,
    val_set: TileSet,
    cfg: TrainConfig = TrainConfig(),
    *,
    seed: int,
    threads: int = 1,
    logger: logging.Logger | None = None,
) -> TrainResult:
    """Train one classifier with seed ``seed`` (same seed and threads => same result).

    Parameters
    ----------
    train_set, val_set : TileSet
        Images float32 [n, T, D] in dB, targets bird/drone
        (``microdoppler.classifier.load_trainset``).
    cfg : TrainConfig
        Architecture and training settings.
    seed : int
        Seeds initialisation, dropout and shuffling.
    threads : int
        torch intra-op threads.
    logger : logging.Logger, optional
        Where the epochs are logged.

    Returns
    -------
    TrainResult
        ``model`` (the kept epoch's, in eval mode), ``history`` (one row per epoch)
        and ``best_epoch`` (1-based).

    Raises
    ------
    microdoppler.errors.InputError
        When the training set has no tiles.

    See Also
    --------
    TrainConfig, predict, build_model

    Examples
    --------
    One epoch on toy tiles (``toy_tiles``: noise and lines, not physics):

    >>> from microdoppler.classifier import TrainConfig, train
    >>> from microdoppler.classifier.data import toy_tiles
    >>> tiles = toy_tiles(16, seed=0, n_timesteps=8, n_bins=64)
    >>> result = train(tiles, tiles, TrainConfig(max_epochs=1, compact={"doppler_pool": 4}), seed=0)
    >>> result.best_epoch, list(result.history.epoch)
    (1, [1])
    """
    logger = logger or log
    if len(train_set) == 0:
        raise InputError("training set", "train", "has no tiles", "at least one training tile")
    classes = set(train_set.labels["target"])
    if len(classes) < 2:
        only = ", ".join(sorted(map(str, classes)))
        missing = " and ".join(c for c in ("bird", "drone") if c not in classes)
        raise InputError(
            "training set",
            "train.target",
            f"has {only} tiles only ({len(train_set)} tiles of {train_set.labels['flight_id'].nunique()} flights)",
            f"tiles of both classes, bird and drone: add {missing} recordings to train a bird/drone classifier",
        )
    if len(val_set) and len(set(val_set.labels["target"])) < 2:
        logger.warning(
            "the validation tiles hold one class only (%s): validation accuracy measures that class alone",
            ", ".join(sorted(map(str, set(val_set.labels["target"])))),
        )
    if len(val_set) == 0:
        logger.warning(
            "no validation tiles: validation loss/accuracy are NaN, the stopping rule never fires "
            "and the kept epoch maximises training accuracy alone"
        )
    gen = setup_determinism(seed, threads)
    model = build_model(
        cfg.architecture,
        compact=cfg.compact,
        colormap=cfg.colormap,
        alexnet_weights=cfg.alexnet_weights,
        normalisation=cfg.normalisation,
    )
    xt = torch.from_numpy(cfg.normalisation(train_set.images))
    yt = torch.from_numpy(train_set.y)
    xv = torch.from_numpy(cfg.normalisation(val_set.images))
    yv = torch.from_numpy(val_set.y)
    params = [p for p in model.parameters() if p.requires_grad]
    opt = torch.optim.SGD(params, lr=cfg.learning_rate, momentum=cfg.momentum, weight_decay=cfg.weight_decay)
    sched = torch.optim.lr_scheduler.StepLR(opt, step_size=cfg.lr_step_epochs, gamma=cfg.lr_gamma)
    logger.info(
        "training %s: %d train (%d drone), %d validation tiles, %d trainable parameters, seed %d",
        cfg.architecture,
        len(xt),
        int(yt.sum()),
        len(xv),
        sum(p.numel() for p in params),
        seed,
    )
    rows, states = [], []
    for epoch in range(cfg.max_epochs):
        t0 = time.perf_counter()
        lr = opt.param_groups[0]["lr"]
        run_loss, run_acc = train_epoch(model, opt, gen, xt, yt, cfg.batch_size, cfg.augment)
        sched.step()
        if cfg.reevaluate_train:
            tr_loss, tr_acc = _evaluate(model, xt, yt, 256)
        else:
            tr_loss, tr_acc = run_loss, run_acc
        va_loss, va_acc = _evaluate(model, xv, yv, 256)
        states.append(copy.deepcopy(model.state_dict()))
        rows.append(
            dict(
                epoch=epoch + 1,
                learning_rate=lr,
                train_loss=tr_loss,
                train_accuracy=tr_acc,
                val_loss=va_loss,
                val_accuracy=va_acc,
                val_exceeds_train=va_loss > tr_loss,
                seconds=time.perf_counter() - t0,
            )
        )
        logger.info(
            "epoch %3d  lr %.2e  train loss %.4f acc %.3f  val loss %.4f acc %.3f  (%.1f s)",
            epoch + 1,
            lr,
            tr_loss,
            tr_acc,
            va_loss,
            va_acc,
            rows[-1]["seconds"],
        )
        hist = pd.DataFrame(rows)
        if stop_epoch(hist["val_loss"], hist["train_loss"], cfg.exceed_limit) is not None:
            logger.info("stopping: validation loss exceeded training loss %d times", cfg.exceed_limit)
            break
    hist = pd.DataFrame(rows)
    if cfg.average_last_epochs > 0:
        kept = states[-cfg.average_last_epochs :]
        model.load_state_dict(average_states(kept))
        best = len(states) - 1
        hist["selected"] = hist.index >= len(states) - len(kept)
        logger.info("kept the average of the weights of epochs %d-%d", len(states) - len(kept) + 1, len(states))
    else:
        best = best_epoch(hist["train_accuracy"], hist["val_accuracy"])
        hist["selected"] = hist.index == best
        model.load_state_dict(states[best])
        logger.info(
            "kept epoch %d (train acc %.3f + val acc %.3f)",
            best + 1,
            hist["train_accuracy"][best],
            hist["val_accuracy"][best],
        )
    model.eval()
    return TrainResult(model, hist, best + 1)


def average_states(states: list[dict]) -> dict:
    """Element-wise mean of state dicts of one model (floating tensors; integer
    buffers are taken from the last state)."""
    out = {}
    for k, v in states[-1].items():
        if torch.is_floating_point(v):
            out[k] = torch.stack([s[k] for s in states]).mean(0).to(v.dtype)
        else:
            out[k] = v.clone()
    return out


def save_model(path, result: TrainResult, cfg: TrainConfig, *, seed: int, trainset: str) -> None:
    """Save the kept model, its config and provenance to ``path`` (atomically)."""
    from ..io.outputs import atomic_file

    # through a file object: torch.save given a path names the archive's entries after
    # it (the random temporary name), and the same model would not give the same bytes
    with atomic_file(path) as tmp, open(tmp, "wb") as fh:
        torch.save(
            {
                "state_dict": result.model.state_dict(),
                "config": cfg.to_dict(),
                "seed": int(seed),
                "trainset": trainset,
                "best_epoch": int(result.best_epoch),
            },
            fh,
        )


def load_model(path) -> tuple[torch.nn.Module, TrainConfig]:
    """Load a model saved by :func:`save_model` (eval mode) and its config."""
    blob = torch.load(path, map_location="cpu", weights_only=False)
    cfg = TrainConfig.from_config(blob["config"])
    # pretrained conv weights are in the state_dict: do not need the original file
    model = build_model(
        cfg.architecture,
        compact=cfg.compact,
        colormap=cfg.colormap,
        alexnet_weights="",
        normalisation=cfg.normalisation,
    )
    model.load_state_dict(blob["state_dict"])
    model.eval()
    return model, cfg
