"""Classifier models and the per-image normalisation of dB tiles.

Two architectures (``architecture`` in the config):

* ``compact`` (default): a small CNN for 20 x 480 dB tiles, trained from scratch.
  It keeps the Doppler axis long (HERM sidebands are a Doppler pattern) and pools
  it early, so 45 training runs fit the default profile's time budget on 2 cores.
* ``alexnet``: AlexNet as in the paper (§IV; 5 convolutional + 3 fully connected
  layers) in plain torch, with torchvision's parameter names, so a torchvision
  ImageNet ``state_dict`` saved to a local file loads as is. Tiles become
  224 x 224 RGB images through a false-colour map. With pretrained weights only
  the fully connected layers are trained (re-initialised, 2 outputs), as in the
  paper; without them the whole network is trained from scratch.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from ..configfields import knob
from ..errors import ConfigError, InputError

ARCHITECTURES = ("compact", "alexnet")
IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


@dataclass(frozen=True)
class Normalisation:
    """Per-image normalisation of dB tiles.

    ``x = clip((db - median(db)) / scale_db, low_db / scale_db, high_db / scale_db)``.

    The tiles are uncalibrated dB: their absolute level moves with range, radar and
    receiver gain, none of which says bird or drone. The tile median is a robust
    estimate of the noise/clutter floor (the target occupies few of the 480 bins),
    so subtracting it leaves the target-to-floor contrast that the paper's colour
    map shows. Values far below the floor are noise fluctuations (clipped at
    ``low_db``); ``high_db`` bounds the dynamic range like the colour map's limits.
    Dividing by ``scale_db`` brings values to order one for SGD.

    Parameters
    ----------
    low_db, high_db : float
        Clip limits relative to the tile median [dB]; ``low_db < high_db``.
    scale_db : float
        Divisor [dB]; > 0.
    """

    low_db: float = knob(-10.0, "Lower clip relative to the median [dB].")
    high_db: float = knob(50.0, "Upper clip relative to the median [dB].")
    scale_db: float = knob(20.0, "Divisor [dB].", exclusive_minimum=0)

    def __post_init__(self):
        if not self.low_db < self.high_db:
            raise ConfigError(
                "classifier.normalisation", "low_db", f"low_db={self.low_db} must be < high_db={self.high_db}"
            )
        if not self.scale_db > 0:
            raise ConfigError("classifier.normalisation", "scale_db", f"scale_db={self.scale_db} must be > 0")

    def __call__(self, images_db: np.ndarray) -> np.ndarray:
        """Normalise ``images_db`` (float [n, T, D] dB) to float32 [n, T, D]."""
        x = np.asarray(images_db, dtype=np.float32)
        if x.ndim != 3:
            raise InputError("images", "shape", f"is {x.shape}", "[n, n_timesteps, n_bins]")
        x = np.nan_to_num(x, nan=0.0, posinf=0.0, neginf=-1e3) if not np.isfinite(x).all() else x
        if x.size == 0:
            return x.copy()
        med = np.median(x.reshape(len(x), -1), axis=1).astype(np.float32)[:, None, None]
        return np.clip((x - med) / self.scale_db, self.low_db / self.scale_db, self.high_db / self.scale_db).astype(
            np.float32
        )


@dataclass(frozen=True)
class CompactSettings:
    """The keys of the config's ``classifier.compact`` (:class:`CompactCNN`'s keyword
    arguments; the defaults are its own)."""

    channels: list[int] = knob(
        description="Output channels per conv block.",
        default_factory=lambda: [6, 12, 24],
        items={"type": "integer", "minimum": 1},
        min_items=1,
    )
    doppler_pool: int = knob(8, "Doppler pooling after the first block.", minimum=1)
    dropout: float = knob(0.2, "Dropout before the linear layer.", minimum=0, maximum=1)


class CompactCNN(nn.Module):
    """Small CNN for [1, T, D] tiles (T timesteps, D Doppler bins).

    Conv blocks (3 x 5 then 3 x 3 kernels, ReLU, max-pooling) with the first
    pooling along Doppler only (``doppler_pool``), then global average and max
    pooling over time and Doppler, dropout and one linear layer to 2 classes.

    Parameters
    ----------
    channels : tuple of int
        Output channels of each conv block.
    doppler_pool : int
        Pooling factor along Doppler after the first block.
    dropout : float
        Dropout before the last layer.
    """

    def __init__(self, channels=(6, 12, 24), doppler_pool: int = 8, dropout: float = 0.2, n_classes: int = 2):
        super().__init__()
        if not channels or any(c < 1 for c in channels):
            raise ConfigError("classifier.compact", "channels", f"channels={channels} must be positive integers")
        if doppler_pool < 1:
            raise ConfigError("classifier.compact", "doppler_pool", f"doppler_pool={doppler_pool} must be >= 1")
        layers, c_in = [], 1
        for i, c in enumerate(channels):
            k = (3, 5) if i == 0 else (3, 3)
            layers += [
                nn.Conv2d(c_in, c, k, padding=(k[0] // 2, k[1] // 2)),
                nn.ReLU(inplace=True),
                nn.MaxPool2d((1, doppler_pool) if i == 0 else (2, 2), ceil_mode=True),
            ]
            c_in = c
        self.features = nn.Sequential(*layers)
        self.dropout = nn.Dropout(dropout)
        self.fc = nn.Linear(2 * c_in, n_classes)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """x : float32 [batch, T, D] normalised tiles -> logits [batch, 2]."""
        h = self.features(x.unsqueeze(1))
        h = torch.cat([h.mean(dim=(2, 3)), h.amax(dim=(2, 3))], dim=1)
        return self.fc(self.dropout(h))


class AlexNet(nn.Module):
    """AlexNet (Krizhevsky et al. 2012, torchvision layout) on colour-mapped tiles.

    Input: normalised tiles float32 [batch, T, D]; they are mapped to RGB with
    ``colormap``, resized to 224 x 224 (bilinear) and standardised with the
    ImageNet mean and std before the 5 conv + 3 FC layers.
    """

    def __init__(self, n_classes: int = 2, colormap: str = "jet", value_range=(-0.5, 2.5), dropout: float = 0.5):
        super().__init__()
        self.features = nn.Sequential(
            nn.Conv2d(3, 64, 11, stride=4, padding=2),
            nn.ReLU(inplace=True),
            nn.MaxPool2d(3, 2),
            nn.Conv2d(64, 192, 5, padding=2),
            nn.ReLU(inplace=True),
            nn.MaxPool2d(3, 2),
            nn.Conv2d(192, 384, 3, padding=1),
            nn.ReLU(inplace=True),
            nn.Conv2d(384, 256, 3, padding=1),
            nn.ReLU(inplace=True),
            nn.Conv2d(256, 256, 3, padding=1),
            nn.ReLU(inplace=True),
            nn.MaxPool2d(3, 2),
        )
        self.avgpool = nn.AdaptiveAvgPool2d((6, 6))
        self.classifier = nn.Sequential(
            nn.Dropout(dropout),
            nn.Linear(256 * 6 * 6, 4096),
            nn.ReLU(inplace=True),
            nn.Dropout(dropout),
            nn.Linear(4096, 4096),
            nn.ReLU(inplace=True),
            nn.Linear(4096, n_classes),
        )
        self.register_buffer("lut", colormap_lut(colormap), persistent=False)
        self.register_buffer("mean", torch.tensor(IMAGENET_MEAN).view(1, 3, 1, 1), persistent=False)
        self.register_buffer("std", torch.tensor(IMAGENET_STD).view(1, 3, 1, 1), persistent=False)
        self.value_range = tuple(float(v) for v in value_range)

    def to_rgb(self, x: torch.Tensor) -> torch.Tensor:
        """Normalised tiles [batch, T, D] -> ImageNet-standardised RGB [batch, 3, 224, 224]."""
        lo, hi = self.value_range
        n = self.lut.shape[0]
        idx = ((x - lo) / (hi - lo) * (n - 1)).round().clamp(0, n - 1).long()
        rgb = self.lut[idx].permute(0, 3, 1, 2)  # [b, 3, T, D]
        rgb = F.interpolate(rgb, size=(224, 224), mode="bilinear", align_corners=False)
        return (rgb - self.mean) / self.std

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = self.avgpool(self.features(self.to_rgb(x)))
        return self.classifier(torch.flatten(h, 1))


def colormap_lut(name: str, n: int = 256) -> torch.Tensor:
    """RGB look-up table float32 [n, 3] of a matplotlib colour map."""
    from matplotlib import colormaps

    if name not in colormaps:
        raise ConfigError("classifier", "colormap", f"colormap={name!r} is not a matplotlib colour map")
    return torch.tensor(colormaps[name](np.linspace(0, 1, n))[:, :3], dtype=torch.float32)


def load_pretrained_alexnet(model: AlexNet, weights_path) -> None:
    """Load ImageNet conv weights from a torchvision AlexNet ``state_dict`` file.

    The conv layers (``features.*``) are loaded and frozen; the fully connected
    layers keep their fresh random initialisation (2 outputs) and are the only
    ones trained, as in the paper (§IV).
    """
    path = Path(weights_path)
    if not path.is_file():
        raise InputError(
            path, "classifier.alexnet_weights", "file not found", "a torchvision AlexNet state_dict (.pth)"
        )
    state = torch.load(path, map_location="cpu", weights_only=True)
    if isinstance(state, dict) and "state_dict" in state:
        state = state["state_dict"]
    feats = {k[len("features.") :]: v for k, v in state.items() if k.startswith("features.")}
    try:
        model.features.load_state_dict(feats, strict=True)
    except RuntimeError as exc:
        raise InputError(
            path,
            "features",
            f"does not match AlexNet: {str(exc).splitlines()[0]}",
            "torchvision AlexNet parameter names and shapes",
        ) from None
    for p in model.features.parameters():
        p.requires_grad_(False)


def build_model(
    architecture: str = "compact",
    *,
    compact: dict | None = None,
    colormap: str = "jet",
    alexnet_weights: str = "",
    normalisation: Normalisation = Normalisation(),
) -> nn.Module:
    """Build an untrained classifier (initialised from torch's current RNG state).

    Parameters
    ----------
    architecture : {'compact', 'alexnet'}
        The small CNN over [T, D] tiles, or the paper's AlexNet over false-colour
        images.
    compact : dict
        Keyword arguments of ``CompactCNN`` (channels, doppler_pool, dropout).
    colormap : str
        False-colour map of the AlexNet input.
    alexnet_weights : str
        Local torchvision AlexNet state_dict; empty = train AlexNet from scratch.
    normalisation : Normalisation
        Gives the AlexNet colour map's value range.

    Returns
    -------
    torch.nn.Module
        Maps normalised tiles float32 [n, T, D] to logits float32 [n, 2] (bird, drone).

    Raises
    ------
    microdoppler.errors.ConfigError
        For an unknown architecture or out-of-range CNN settings.

    See Also
    --------
    train, predict

    Examples
    --------
    >>> import torch
    >>> from microdoppler.classifier import build_model
    >>> _ = torch.manual_seed(0)
    >>> model = build_model("compact", compact={"doppler_pool": 4})
    >>> model(torch.zeros(2, 8, 64)).shape
    torch.Size([2, 2])
    """
    if architecture == "compact":
        return CompactCNN(**(compact or {}))
    if architecture == "alexnet":
        lo, hi = normalisation.low_db / normalisation.scale_db, normalisation.high_db / normalisation.scale_db
        model = AlexNet(colormap=colormap, value_range=(lo, hi))
        if alexnet_weights:
            load_pretrained_alexnet(model, alexnet_weights)
        return model
    raise ConfigError("classifier", "architecture", f"architecture={architecture!r} must be one of {ARCHITECTURES}")
