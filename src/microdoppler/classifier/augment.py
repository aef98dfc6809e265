"""Training-time augmentation of normalised tiles along the Doppler axis.

A classifier trained on twins meets measured flights whose HERM lines differ from
the twins' in ways the twin cannot know per image: how widely a line is smeared by
the rotor speeds' change within a CPI, and where exactly the lines sit (rotor speeds
of the same drone model differ by flight). Two seeded transforms widen the training
distribution along those axes; neither changes a tile's class:

* ``doppler_blur_bins``: each augmented tile is convolved along Doppler with a
  Gaussian of standard deviation drawn uniformly in [0, ``doppler_blur_bins``] bins
  (on the normalised dB values; edges replicated).
* ``doppler_stretch``: each augmented tile's Doppler axis is rescaled about its
  centre (zero Doppler, where the clutter notch sits) by a factor drawn uniformly in
  [1 - s, 1 + s] (linear interpolation): every line moves proportionally, as with a
  rotor a fraction s faster or slower and a body that much faster or slower.
* ``doppler_wander``: the rescaling factor changes along the tile's time axis,
  1 + w sin(2 pi (c t / T + phi)) with w drawn in [0, ``doppler_wander``], c in [0, 2]
  cycles per tile and phi in [0, 1): lines move up and down over the tile's
  timesteps as measured rotor lines do when the speeds change, where a twin made
  with constant speeds has straight lines.

A tile is augmented with ``probability``. Every draw comes from the training run's
own generator, so the same seed gives the same run; with every transform off
(default) nothing is drawn and training is exactly as without this module.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch.nn import functional as F

from ..errors import ConfigError
from ..configfields import knob


@dataclass(frozen=True)
class Augmentation:
    """Doppler-axis augmentation of training tiles (module doc).

    Parameters
    ----------
    doppler_blur_bins : float
        Largest Gaussian blur standard deviation [Doppler bins]; 0 disables.
    doppler_stretch : float
        Largest relative rescaling of the Doppler axis, in [0, 0.5); 0 disables.
    doppler_wander : float
        Largest amplitude of a rescaling that varies along time, in [0, 0.5); 0 disables.
    probability : float
        Share of training tiles augmented (per tile, per epoch), in [0, 1].
    """

    doppler_blur_bins: float = knob(
        0.0, "Largest blur standard deviation [Doppler bins]; 0: no blur.", minimum=0, maximum=50
    )
    doppler_stretch: float = knob(
        0.0, "Largest relative rescaling of the Doppler axis; 0: none.", minimum=0, exclusive_maximum=0.5
    )
    doppler_wander: float = knob(
        0.0,
        "Largest amplitude of a rescaling that varies along time (0 to 2 cycles per tile, phase drawn); 0: none.",
        minimum=0,
        exclusive_maximum=0.5,
    )
    probability: float = knob(0.5, "Share of training tiles augmented, per tile and epoch.", minimum=0, maximum=1)

    def __post_init__(self):
        checks = [
            (
                "doppler_blur_bins",
                math.isfinite(self.doppler_blur_bins) and 0 <= self.doppler_blur_bins <= 50,
                "in [0, 50]",
            ),
            ("doppler_stretch", math.isfinite(self.doppler_stretch) and 0 <= self.doppler_stretch < 0.5, "in [0, 0.5)"),
            ("doppler_wander", math.isfinite(self.doppler_wander) and 0 <= self.doppler_wander < 0.5, "in [0, 0.5)"),
            ("probability", math.isfinite(self.probability) and 0 <= self.probability <= 1, "in [0, 1]"),
        ]
        for name, ok, want in checks:
            if not ok:
                raise ConfigError("classifier.augment", name, f"{name}={getattr(self, name)} must be {want}")

    @property
    def active(self) -> bool:
        """True when any transform is on (and applied to a non-zero share of tiles)."""
        return self.probability > 0 and (
            self.doppler_blur_bins > 0 or self.doppler_stretch > 0 or self.doppler_wander > 0
        )

    def __call__(self, x: torch.Tensor, gen: torch.Generator) -> torch.Tensor:
        """Augment a mini-batch ``x`` (float32 [b, T, D], normalised) with draws from ``gen``."""
        if not self.active or len(x) == 0:
            return x
        b = len(x)
        on = torch.rand(b, generator=gen) < self.probability
        if self.doppler_stretch > 0:
            s = 1.0 + self.doppler_stretch * (2.0 * torch.rand(b, generator=gen) - 1.0)
            x = stretch_doppler(x, torch.where(on, s, torch.ones_like(s)))
        if self.doppler_wander > 0:
            t = x.shape[1]
            w = self.doppler_wander * torch.rand(b, 1, generator=gen)
            c = 2.0 * torch.rand(b, 1, generator=gen)
            phi = torch.rand(b, 1, generator=gen)
            tt = torch.arange(t, dtype=x.dtype)[None, :] / max(t, 1)
            s = 1.0 + w * torch.sin(2 * math.pi * (c * tt + phi))  # [b, T]
            x = stretch_doppler(x, torch.where(on[:, None], s, torch.ones_like(s)))
        if self.doppler_blur_bins > 0:
            sig = self.doppler_blur_bins * torch.rand(b, generator=gen)
            x = blur_doppler(x, torch.where(on, sig, torch.zeros_like(sig)))
        return x


def blur_doppler(x: torch.Tensor, sigma_bins: torch.Tensor) -> torch.Tensor:
    """Gaussian blur along the last axis of ``x`` [b, T, D] with one standard deviation
    per image ``sigma_bins`` [b] (0 leaves that image unchanged); edges replicated."""
    b, t, d = x.shape
    smax = float(sigma_bins.max()) if b else 0.0
    if smax <= 0:
        return x
    half = int(math.ceil(3.0 * smax))
    u = torch.arange(-half, half + 1, dtype=x.dtype)
    s = sigma_bins.to(x.dtype).clamp_min(1e-3)[:, None]
    w = torch.exp(-0.5 * (u[None, :] / s) ** 2)
    w = w / w.sum(dim=1, keepdim=True)  # sigma ~ 0: a unit impulse
    xp = F.pad(x.reshape(1, b * t, d), (half, half), mode="replicate")
    return F.conv1d(xp, w.repeat_interleave(t, dim=0)[:, None, :], groups=b * t).reshape(b, t, d)


def stretch_doppler(x: torch.Tensor, factor: torch.Tensor) -> torch.Tensor:
    """Rescale the Doppler axis (last) of ``x`` [b, T, D] about its centre by ``factor``
    [b] (one factor per image) or [b, T] (one per image and timestep; > 1 moves lines
    outward), by linear interpolation; bins that come from outside the tile take the
    nearest edge value."""
    b, t, d = x.shape
    if d < 2:
        return x
    c = (d - 1) / 2.0
    fac = factor.to(x.dtype)
    fac = (fac[:, None] if fac.ndim == 1 else fac)[:, :, None]  # [b, 1 or T, 1]
    pos = torch.arange(d, dtype=x.dtype)
    src = c + (pos[None, None, :] - c) / fac  # [b, 1 or T, D]
    src = src.clamp(0, d - 1)
    i0 = src.floor().long().clamp(max=d - 2)
    f = src - i0.to(x.dtype)
    idx0 = i0.expand(b, t, d)
    f = f.expand(b, t, d)
    return x.gather(2, idx0) * (1 - f) + x.gather(2, idx0 + 1) * f
