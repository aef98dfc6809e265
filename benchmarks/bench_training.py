"""Training throughput of the classifiers and the estimated wall time of the paper profile.

    python benchmarks/bench_training.py [--batches 8] [--epochs 6]
    python benchmarks/bench_training.py --schedules TILES_DIR --seed 1 [--json out.json]

Measures forward+backward (SGD step, batch 16) and inference throughput in
images/s for the compact CNN and AlexNet (from scratch, and FC layers only as with
pretrained weights), with 2 threads (one job using both cores) and 1 thread (two
jobs side by side, the pipeline's default). Then estimates the wall time of the
``paper`` profile (Table III: 7256 train + 713 validation images, 3632 test; 6
training sets x 9 seeds = 54 runs) on 2 cores, assuming every run goes to the
epoch cap (worst case) and is evaluated on the validation set after every epoch
(the config default reevaluate_train: false; the paper's true is printed too).
Target: at most 90 minutes for the default (compact) model.

``--schedules TILES_DIR`` instead trains the configured classifier (config/config.yaml)
on the ``real`` training set of TILES_DIR (its ``real.zarr``) with one seed and
compares shorter epoch schedules: one trunk run with the config's schedule, branched
(same weights, optimiser, dropout and shuffling states) into each shorter schedule at
the epoch before its first learning-rate decay, which makes each branch the run that
``train()`` would give with that schedule (``--check`` verifies this on a subset).
Reports test metrics (``seed_metrics``) and the CPU seconds (time.process_time, 1
thread) of normalisation, training epochs, per-epoch validation and test prediction.
"""

from __future__ import annotations

import argparse
import copy
import json
import time

import torch
from torch.nn import functional as F

from microdoppler.classifier.models import build_model

N_TRAIN, N_VAL, N_TEST, N_RUNS = 7256, 713, 3632, 54
WALL: list = []  # wall-clock rates of the last measurements (contention shows as wall << CPU rate)
STARTUP_S = (
    8.0  # per run: python + torch import, snakemake job, reading tiles (train + evaluate jobs; measured ~3-4 s each)
)


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


# (max_epochs, lr_step_epochs, average_last_epochs): shorter schedules branched off the config's
SCHEDULES = ((6, 5, 3), (6, 5, 2), (8, 7, 3), (8, 7, 4), (6, 4, 3), (8, 6, 3))


def _epoch(model, opt, gen, xt, yt, xv, yv, batch_size):
    """One epoch as in ``training.train`` (reevaluate_train: false); CPU seconds of each part."""
    from microdoppler.classifier.training import _evaluate, train_epoch

    c0 = time.process_time()
    tr_loss, tr_acc = train_epoch(model, opt, gen, xt, yt, batch_size)
    c1 = time.process_time()
    va_loss, va_acc = _evaluate(model, xv, yv, 256)
    return dict(
        train_loss=tr_loss,
        train_accuracy=tr_acc,
        val_loss=va_loss,
        val_accuracy=va_acc,
        cpu_train_s=c1 - c0,
        cpu_val_s=time.process_time() - c1,
    )


def schedules(train_set, val_set, test_set, cfg, seed: int, schedules=SCHEDULES) -> dict:
    """Test metrics and CPU seconds of the config's schedule and of shorter ones (one seed).

    Returns {name: {metrics, epochs, cpu_train_s, cpu_val_s, cpu_test_s, ...}}, names
    ``e{max_epochs}_s{lr_step_epochs}_a{average_last_epochs}``, plus ``cpu_setup_s``
    (normalisation) and the kept state dicts under ``states``.
    """
    import pandas as pd

    from microdoppler.classifier.evaluation import predict, predictions_table
    from microdoppler.classifier.metrics import seed_metrics
    from microdoppler.classifier.training import average_states, setup_determinism, stop_epoch

    def new_model():
        return build_model(
            cfg.architecture, compact=cfg.compact, colormap=cfg.colormap, normalisation=cfg.normalisation
        )

    def new_opt(model):
        return torch.optim.SGD(
            model.parameters(), lr=cfg.learning_rate, momentum=cfg.momentum, weight_decay=cfg.weight_decay
        )

    out, kept = {}, {}
    c0 = time.process_time()
    gen = setup_determinism(seed, 1)
    model = new_model()
    xt, yt = torch.from_numpy(cfg.normalisation(train_set.images)), torch.from_numpy(train_set.y)
    xv, yv = torch.from_numpy(cfg.normalisation(val_set.images)), torch.from_numpy(val_set.y)
    out["cpu_setup_s"] = time.process_time() - c0
    opt = new_opt(model)
    sched = torch.optim.lr_scheduler.StepLR(opt, step_size=cfg.lr_step_epochs, gamma=cfg.lr_gamma)
    branch_at = {min(step, e) for e, step, _ in schedules}
    if max(branch_at) > min(cfg.lr_step_epochs, cfg.max_epochs):
        raise ValueError(f"schedules {schedules} branch after the config's first decay (epoch {cfg.lr_step_epochs})")
    snaps, rows, states = {}, [], []
    for e in range(cfg.max_epochs):
        if e in branch_at:
            snaps[e] = (
                copy.deepcopy(model.state_dict()),
                copy.deepcopy(opt.state_dict()),
                torch.get_rng_state(),
                gen.get_state(),
                list(states),
                list(rows),
            )
        row = _epoch(model, opt, gen, xt, yt, xv, yv, cfg.batch_size)
        row["lr"] = opt.param_groups[0]["lr"]
        sched.step()
        states.append(copy.deepcopy(model.state_dict()))
        rows.append(row)
        print(f"seed {seed} epoch {e + 1}: " + ", ".join(f"{k} {v:.4g}" for k, v in row.items()), flush=True)
        hist = pd.DataFrame(rows)
        if stop_epoch(hist["val_loss"], hist["train_loss"], cfg.exceed_limit) is not None:
            break

    def evaluate(name, st, rw, average):
        c = time.process_time()
        m = new_model()
        m.load_state_dict(average_states(st[-average:]) if average else st[-1])
        m.eval()
        kept[name] = m.state_dict()
        met = seed_metrics(predictions_table(test_set, predict(m, test_set.images, cfg.normalisation)))
        out[name] = dict(
            metrics=met,
            epochs=len(rw),
            average_last_epochs=average,
            lr=[r["lr"] for r in rw],
            cpu_train_s=sum(r["cpu_train_s"] for r in rw),
            cpu_val_s=sum(r["cpu_val_s"] for r in rw),
            cpu_test_s=time.process_time() - c,
        )
        print(f"seed {seed} {name}: test accuracy {met['accuracy']:.4f}", flush=True)

    evaluate(
        f"e{cfg.max_epochs}_s{cfg.lr_step_epochs}_a{cfg.average_last_epochs}", states, rows, cfg.average_last_epochs
    )
    for epochs, step, average in schedules:
        model_state, opt_state, rng, gen_state, st, rw = snaps[min(step, epochs)]
        m = new_model()
        m.load_state_dict(model_state)
        o = new_opt(m)
        o.load_state_dict(opt_state)
        torch.set_rng_state(rng)
        g = torch.Generator()
        g.set_state(gen_state)
        st, rw = list(st), list(rw)
        for e in range(min(step, epochs), epochs):
            lr = cfg.learning_rate
            for _ in range(e // step):  # StepLR's chained product
                lr = lr * cfg.lr_gamma
            o.param_groups[0]["lr"] = lr
            row = _epoch(m, o, g, xt, yt, xv, yv, cfg.batch_size)
            row["lr"] = lr
            st.append(copy.deepcopy(m.state_dict()))
            rw.append(row)
        evaluate(f"e{epochs}_s{step}_a{average}", st, rw, average)
    out["states"] = kept
    return out


def _check_branching(train_set, val_set, test_set, cfg) -> None:
    """The branched schedules equal ``train()`` with those schedules (a 200-tile subset)."""
    from dataclasses import replace

    import numpy as np

    from microdoppler.classifier.training import train

    rng = np.random.default_rng(0)
    tr = train_set.subset(rng.permutation(len(train_set)) < 200)
    va, te = val_set.subset(np.arange(len(val_set)) < 60), test_set.subset(np.arange(len(test_set)) < 60)
    small = replace(cfg, max_epochs=7, lr_step_epochs=5, average_last_epochs=4)
    got = schedules(tr, va, te, small, seed=2, schedules=((6, 4, 3),))["states"]
    for name, c in (
        ("e7_s5_a4", small),
        ("e6_s4_a3", replace(cfg, max_epochs=6, lr_step_epochs=4, average_last_epochs=3)),
    ):
        ref = train(tr, va, c, seed=2).model.state_dict()
        same = all(torch.equal(got[name][k], ref[k]) for k in ref)
        print(f"check {name}: branched run {'==' if same else '!='} train()")
        if not same:
            raise SystemExit(1)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batches", type=int, default=8, help="timed mini-batches per measurement")
    ap.add_argument("--epochs", type=int, default=6, help="epochs per run assumed (the config's max_epochs)")
    ap.add_argument("--schedules", metavar="TILES_DIR", help="compare epoch schedules on TILES_DIR/real.zarr")
    ap.add_argument("--seed", type=int, default=1, help="training seed of --schedules")
    ap.add_argument("--config", default="config/config.yaml", help="config whose classifier: section is trained")
    ap.add_argument("--check", action="store_true", help="with --schedules: first check branching == train()")
    ap.add_argument("--json", help="with --schedules: write the results here")
    args = ap.parse_args(argv)
    if args.schedules:
        import yaml

        from microdoppler.classifier import TrainConfig, load_trainset

        torch.set_num_threads(1)
        with open(args.config) as fh:
            cfg = TrainConfig.from_config(yaml.safe_load(fh)["classifier"])
        parts = load_trainset("real", args.schedules)
        if args.check:
            _check_branching(*parts, cfg)
        res = schedules(*parts, cfg, seed=args.seed)
        res.pop("states")
        if args.json:
            with open(args.json, "w") as fh:
                json.dump(res, fh, indent=1)
        return
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
    print(
        f"paper profile: {N_TRAIN} train + {N_VAL} validation, {N_TEST} test images; {N_RUNS} runs; "
        f"{args.epochs} epochs per run (cap reached, worst case); {STARTUP_S:.0f} s start-up per run"
    )
    print(
        f"{'model':<20}{'train img/s':>12}{'eval img/s':>12}{'train img/s':>12}{'eval img/s':>12}"
        f"{'paper 54 runs':>15}{'jobs':>6}"
    )
    print(f"{'':<20}{'(2 threads)':>12}{'(2 threads)':>12}{'(1 thread)':>12}{'(1 thread)':>12}{'[min, 2 cores]':>15}")
    for name, tr2, ev2, tr1, ev1, minutes, how in rows:
        print(f"{name:<20}{tr2:>12.0f}{ev2:>12.0f}{tr1:>12.0f}{ev1:>12.0f}{minutes:>15.0f}{how:>6}")
    print(
        "rates are per CPU second x threads (idle-machine rates); wall-clock rates seen now: "
        + "; ".join(f"{k}: " + "/".join(f"{w:.0f}" for w in v) for k, v in walls.items())
    )
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
