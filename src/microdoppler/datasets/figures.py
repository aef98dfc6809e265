"""Measured and twin spectrograms side by side, one figure per drone model (paper
Fig. 9 and 10): the measured flight, then its injected twin of every variant, on the
same colour range (60 dB below each panel's peak, ``figures.plot_spectrogram``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.flightzarr import read_flight
from ..spectra.spectrogram import SpectrogramConfig, spectrogram
from .injection import INJECTED_SCHEMA
from .stores import flight_ids, open_store


def _imshow(ax, spec, title):
    try:  # the project's one spectrogram plot
        from ..figures import plot_spectrogram
    except ImportError:
        plot_spectrogram = None
    if plot_spectrogram is not None:
        plot_spectrogram(ax, spec, title=title)
        return
    p = spec.power_db.T
    ax.imshow(
        p,
        aspect="auto",
        origin="lower",
        cmap="jet",
        vmin=float(p.max()) - 60,
        vmax=float(p.max()),
        extent=[spec.time_s[0], spec.time_s[-1], spec.doppler_hz[0], spec.doppler_hz[-1]],
    )
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("time [s]")


def pick_flight(stores: dict, drone_model: str, measured_dir) -> str | None:
    """The longest flight of ``drone_model`` that has a twin in every variant."""
    common = None
    for root in stores.values():
        ids = {f for f in flight_ids(root) if root[f].attrs.get("drone_model") == drone_model}
        common = ids if common is None else common & ids
    if not common:
        return None
    return max(sorted(common), key=lambda f: next(iter(stores.values()))[f]["iq"].shape[0])


def plot_twins(
    measured_dir, injected: dict, drone_model: str, out_png, *, spec_cfg: SpectrogramConfig, max_timesteps: int = 100
) -> str | None:
    """Write the comparison figure of ``drone_model``; returns the flight shown (None:
    no twin of that model, an empty figure saying so is written)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    stores = {v: open_store(p, INJECTED_SCHEMA) for v, p in injected.items()}
    fid = pick_flight(stores, drone_model, measured_dir) if stores else None
    out_png = Path(out_png)
    out_png.parent.mkdir(parents=True, exist_ok=True)
    if fid is None:
        fig, ax = plt.subplots(figsize=(4, 2))
        ax.text(0.5, 0.5, f"no {drone_model} twin", ha="center", va="center")
        ax.axis("off")
        fig.savefig(out_png, dpi=80)
        plt.close(fig)
        return None
    fl = read_flight(Path(measured_dir) / f"{fid}.zarr")
    n = min(len(fl.iq), spec_cfg.n_fft + (max_timesteps - 1) * spec_cfg.hop)
    panels = [("measured", fl.iq[:n])] + [(v, np.asarray(r[fid]["iq"][:n])) for v, r in stores.items()]
    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 2.4 * len(panels)), sharex=True, squeeze=False)
    for ax, (title, iq) in zip(axes[:, 0], panels):
        _imshow(ax, spectrogram(iq, fl.prf_hz, spec_cfg), title)
    fig.suptitle(f"{drone_model} flight {fid} (radar {fl.attrs['radar_id']}): measured vs synthetic twins")
    fig.tight_layout()
    tmp = out_png.with_name(f".{out_png.stem}.tmp.png")
    fig.savefig(tmp, dpi=90)
    plt.close(fig)
    tmp.replace(out_png)
    return fid
