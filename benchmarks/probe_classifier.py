"""What a trained classifier uses: per-class test accuracy on manipulated test tiles.

    .venv/bin/python benchmarks/probe_classifier.py RESULTS_DIR [--trainset real] [--seed 1]

Loads ``RESULTS_DIR/models/{trainset}/seed{seed}.pt`` and the measured test tiles of
``RESULTS_DIR/tiles/real.zarr`` and prints the accuracy per class (bird, Inspire,
Matrice, Mini) on the tiles as they are and after each manipulation: a level shift of
+-10 dB, the Doppler axis flipped, every bin farther than 25 bins from the body line
(the tile's strongest column) set to the tile's median, bins 5-30 from it set to the
median, and each row shifted so that its peak sits on one bin (the body line's motion
within the tile removed). Not in CI.
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from microdoppler.classifier import load_model, predict, read_tiles

CLASSES = ("bird", "inspire2", "matrice300", "mini2")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results")
    ap.add_argument("--trainset", default="real")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args(argv)
    torch.set_num_threads(1)
    model, cfg = load_model(f"{a.results}/models/{a.trainset}/seed{a.seed}.pt")
    real = read_tiles(f"{a.results}/tiles/real.zarr")
    test = real.subset(real.labels["set"] == "test")
    x, lab = test.images, test.labels
    grp = np.where(lab["target"] == "bird", "bird", lab["drone_model"].astype(str))
    y = (lab["target"] == "drone").to_numpy()
    n_dopp = x.shape[2]
    peak = np.array([int(np.argmax(t.mean(0))) for t in x])

    def masked(lo, hi):
        out = x.copy()
        for i in range(len(x)):
            m = np.zeros(n_dopp, bool)
            m[max(0, peak[i] - hi) : peak[i] + hi + 1] = True
            m[max(0, peak[i] - lo + 1) : peak[i] + lo] = False
            out[i][:, m if lo > 0 else ~m] = np.median(x[i])
        return out

    cases = {
        "as is": x,
        "+10 dB": x + 10,
        "-10 dB": x - 10,
        "Doppler flipped": x[:, :, ::-1].copy(),
        "only +-25 bins around the body": masked(0, 25),
        "bins 5-30 from the body at the floor": masked(5, 30),
        "each row's peak on one bin": np.stack(
            [np.stack([np.roll(r, n_dopp // 2 - int(np.argmax(r))) for r in t]) for t in x]
        ),
    }
    print(f"{'manipulation':40s}" + "".join(f"{c:>12s}" for c in CLASSES))
    for name, xm in cases.items():
        ok = (predict(model, xm, cfg.normalisation) > 0.5) == y
        print(f"{name:40s}" + "".join(f"{100 * ok[grp == c].mean():12.1f}" for c in CLASSES))


if __name__ == "__main__":
    main()
