"""Training throughput of the classifiers and the estimated wall time of the paper profile.

    python benchmarks/bench_training.py [--batches 8] [--epochs 12]

Measures forward+backward (SGD step, batch 16) and inference throughput in
images/s for the compact CNN and AlexNet (from scratch, and FC layers only as with
pretrained weights), with 2 threads (one job using both cores) and 1 thread (two
jobs side by side, the pipeline's default). Then estimates the wall time of the
``paper`` profile (Table III: 7256 train + 713 validation images, 3632 test; 5
training sets x 9 seeds = 45 runs) on 2 cores, assuming every run goes to the
epoch cap (worst case) and is evaluated on the validation set after every epoch
(the config default reevaluate_train: false; the paper's true is printed too).
Target: at most 90 minutes for the default (compact) model.
"""

from __future__ import annotations

import argparse
import time

import torch
from torch.nn import functional as F

from microdoppler.classifier.models import build_model

N_TRAIN, N_VAL, N_TEST, N_RUNS = 7256, 713, 3632, 45
WALL: list = []  # wall-clock rates of the last measurements (contention shows as wall << CPU rate)
STARTUP_S = 8.0  # per run: python + torch import, snakemake job, reading tiles (train + evaluate jobs; measured ~3-4 s each)


def throughput(model, threads: int, batches: int, batch: int = 16, shape=(20, 480)) -> tuple[float, float]:
    """(train images/s, inference images/s) of ``model`` on random tiles.

    Rates are per CPU second of this process times ``threads`` (i.e. the wall rate on
    an otherwise idle machine with perfect scaling), so that other processes sharing
    the cores do not distort them; the wall-clock rates are printed alongside.
    """
    torch.set_num_threads(threads)
    torch.manual_seed(0)
    params = [p for p in model.parameters() if p.requires_grad]
    opt = torch.optim.SGD(params, lr=1e-3, momentum=0.9)
    x, y = torch.randn(batch, *shape), torch.randint(0, 2, (batch,))
    model.train()

    def step():
        opt.zero_grad(set_to_none=True)
        F.cross_entropy(model(x), y).backward()
        opt.step()

    step()
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(batches):
        step()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    train_rate = batches * batch / max(cpu / threads, 1e-9)
    WALL.append(batches * batch / wall)
    model.eval()
    xe = torch.randn(4 * batch, *shape)
    with torch.no_grad():
        model(xe)
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(max(1, batches // 2)):
            model(xe)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        eval_rate = max(1, batches // 2) * len(xe) / max(cpu / threads, 1e-9)
        WALL.append(max(1, batches // 2) * len(xe) / wall)
    return train_rate, eval_rate


def run_seconds(train_rate: float, eval_rate: float, epochs: int, reevaluate_train: bool = False) -> float:
    """One training run + evaluation at the paper profile's sizes."""
    per_epoch = N_TRAIN / train_rate + ((N_TRAIN if reevaluate_train else 0) + N_VAL) / eval_rate
    return epochs * per_epoch + N_TEST / eval_rate + STARTUP_S


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batches", type=int, default=8, help="timed mini-batches per measurement")
    ap.add_argument("--epochs", type=int, default=12, help="epochs per run assumed (the config's max_epochs)")
    args = ap.parse_args(argv)
    models = {
        "compact": lambda: build_model("compact"),
        "alexnet (scratch)": lambda: build_model("alexnet"),
        "alexnet (FC only)": lambda: _frozen_alexnet(),
    }
    rows, walls = [], {}
    for name, make in models.items():
        nb = args.batches if name == "compact" else max(2, args.batches // 4)
        WALL.clear()
        r2 = throughput(make(), 2, nb if name != "compact" else 4 * nb)
        r1 = throughput(make(), 1, nb if name != "compact" else 4 * nb)
        walls[name] = list(WALL)
        if name == "compact":
            compact_1thread = r1
        # 2 cores: either 2 jobs x 1 thread side by side, or 1 job x 2 threads; take the faster
        t_2x1 = N_RUNS * run_seconds(*r1, args.epochs) / 2
        t_1x2 = N_RUNS * run_seconds(*r2, args.epochs)
        rows.append((name, *r2, *r1, min(t_2x1, t_1x2) / 60, "2x1" if t_2x1 <= t_1x2 else "1x2"))
    print(f"paper profile: {N_TRAIN} train + {N_VAL} validation, {N_TEST} test images; {N_RUNS} runs; "
          f"{args.epochs} epochs per run (cap reached, worst case); {STARTUP_S:.0f} s start-up per run")
    print(f"{'model':<20}{'train img/s':>12}{'eval img/s':>12}{'train img/s':>12}{'eval img/s':>12}"
          f"{'paper 45 runs':>15}{'jobs':>6}")
    print(f"{'':<20}{'(2 threads)':>12}{'(2 threads)':>12}{'(1 thread)':>12}{'(1 thread)':>12}{'[min, 2 cores]':>15}")
    for name, tr2, ev2, tr1, ev1, minutes, how in rows:
        print(f"{name:<20}{tr2:>12.0f}{ev2:>12.0f}{tr1:>12.0f}{ev1:>12.0f}{minutes:>15.0f}{how:>6}")
    print("rates are per CPU second x threads (idle-machine rates); wall-clock rates seen now: "
          + "; ".join(f"{k}: " + "/".join(f"{w:.0f}" for w in v) for k, v in walls.items()))
    paper = N_RUNS * run_seconds(*compact_1thread, args.epochs, reevaluate_train=True) / 2 / 60
    print(f"compact with reevaluate_train: true (the paper's per-epoch training-set evaluation): {paper:.0f} min")
    ok = rows[0][5] <= 90
    print(f"target <= 90 min for the default model: {'met' if ok else 'NOT met'} ({rows[0][5]:.0f} min)")


def _frozen_alexnet():
    model = build_model("alexnet")
    for p in model.features.parameters():
        p.requires_grad_(False)
    return model


if __name__ == "__main__":
    main()
