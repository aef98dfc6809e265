"""Tests of the classifier: metrics, stopping rule, normalisation, models, training, reports."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import torch

from microdoppler.classifier import (
    AlexNet,
    CompactCNN,
    Normalisation,
    TrainConfig,
    best_epoch,
    class_metrics,
    confusion_matrix,
    load_model,
    predict,
    predictions_table,
    save_model,
    seed_metrics,
    stop_epoch,
    train,
)
from microdoppler.classifier.data import load_trainset, read_tiles, toy_tiles, write_tiles
from microdoppler.classifier.reports import PAPER_FIG6, table_v, write_reports
from microdoppler.errors import InputError


@pytest.fixture
def rng():
    return np.random.default_rng(5)


# --- metrics on hand-made confusion matrices -----------------------------------------


def test_class_metrics_on_paper_fig6():
    m = class_metrics(PAPER_FIG6)  # rows true bird/drone, columns predicted bird/drone
    assert m["accuracy"] == pytest.approx((1661 + 1599) / 3636)
    assert m["bird_recall"] == pytest.approx(1661 / (1661 + 157))
    assert m["drone_recall"] == pytest.approx(1599 / (219 + 1599))
    assert m["bird_precision"] == pytest.approx(1661 / (1661 + 219))
    assert m["drone_precision"] == pytest.approx(1599 / (157 + 1599))
    # the paper's 89.7 % accuracy and its 8.9 % / 11.6 % false-alarm rates
    assert 100 * m["accuracy"] == pytest.approx(89.7, abs=0.05)
    assert 100 * (1 - m["bird_precision"]) == pytest.approx(11.6, abs=0.05)
    assert 100 * (1 - m["drone_precision"]) == pytest.approx(8.9, abs=0.05)


def test_recall_and_precision_differ_when_unbalanced():
    cm = np.array([[90, 10], [40, 60]])  # many drones called birds
    m = class_metrics(cm)
    assert m["drone_recall"] == pytest.approx(0.6)
    assert m["drone_precision"] == pytest.approx(60 / 70)
    assert m["bird_recall"] == pytest.approx(0.9)
    assert m["bird_precision"] == pytest.approx(90 / 130)
    assert m["accuracy"] == pytest.approx(0.75)


def test_confusion_matrix_counts(rng):
    true = rng.choice(["bird", "drone"], 200)
    pred = np.where(rng.random(200) < 0.8, true, rng.choice(["bird", "drone"], 200))
    cm = confusion_matrix(true, pred)
    assert cm.sum() == 200
    assert cm[1, 1] == np.sum((true == "drone") & (pred == "drone"))
    assert cm[0, 1] == np.sum((true == "bird") & (pred == "drone"))
    assert class_metrics(cm)["accuracy"] == pytest.approx(np.mean(true == pred))
    with pytest.raises(InputError):
        confusion_matrix(["bird", "cat"], ["bird", "bird"])


def test_empty_class_gives_nan():
    m = class_metrics(np.array([[5, 0], [0, 0]]))
    assert np.isnan(m["drone_recall"]) and np.isnan(m["drone_precision"])
    assert m["accuracy"] == 1.0


def test_seed_metrics_subgroups():
    pred = pd.DataFrame(
        {
            "target": ["drone"] * 6 + ["bird"] * 4,
            "drone_model": ["inspire2", "matrice300", "inspire2", "mini2", "mini2", "mini2", "", "", "", ""],
            "radar_id": ["1", "2"] * 5,
            "predicted": ["drone", "drone", "bird", "drone", "bird", "bird", "bird", "bird", "drone", "bird"],
        }
    )
    m = seed_metrics(pred)
    assert m["large_drone_accuracy"] == pytest.approx(2 / 3)
    assert m["small_drone_accuracy"] == pytest.approx(1 / 3)
    assert m["drone_recall"] == pytest.approx(3 / 6)
    assert m["accuracy"] == pytest.approx(6 / 10)
    radar1 = pred[pred.radar_id == "1"]
    assert m["accuracy_radar_1"] == pytest.approx((radar1.target == radar1.predicted).mean())


# --- stopping rule and best-epoch selection -----------------------------------------


def test_stop_epoch_counts_exceedances_not_consecutive():
    train_loss = np.full(30, 1.0)
    val_loss = np.where(np.arange(30) % 2 == 1, 1.5, 0.5)  # exceeds on odd epochs
    assert stop_epoch(val_loss, train_loss, 10) == 19  # the 10th odd epoch (0-based)
    assert stop_epoch(val_loss, train_loss, 16) is None
    assert stop_epoch(val_loss, train_loss, 1) == 1
    assert stop_epoch([1.0, 1.0], [1.0, 1.0], 1) is None  # equal is not exceeding


def test_best_epoch_maximises_sum_of_accuracies():
    tr = [0.6, 0.9, 0.95, 0.99, 0.99]
    va = [0.6, 0.85, 0.88, 0.80, 0.84]
    assert best_epoch(tr, va) == 2  # 1.83 beats 1.79 and 1.83 later (first on ties)
    assert best_epoch([0.5, 0.7, 0.7], [0.7, 0.5, 0.5]) == 0


# --- normalisation and models --------------------------------------------------------


def test_normalisation_removes_level_and_clips(rng):
    x = rng.normal(-80, 3, (3, 20, 480)).astype(np.float32)
    x[:, 5, 200] = 0.0  # strong line, 80 dB above the floor
    norm = Normalisation(low_db=-10, high_db=50, scale_db=20)
    y = norm(x)
    y_shift = norm(x + 37.0)  # a different receiver gain
    np.testing.assert_allclose(y, y_shift, atol=1e-5)
    assert np.all(np.abs(np.median(y.reshape(3, -1), axis=1)) < 1e-6)
    assert y.max() == pytest.approx(50 / 20) and y.min() >= -10 / 20 - 1e-7
    with pytest.raises(InputError):
        Normalisation(low_db=5, high_db=1)


def test_compact_cnn_shapes():
    m = CompactCNN()
    assert m(torch.zeros(4, 20, 480)).shape == (4, 2)
    assert m(torch.zeros(1, 20, 128)).shape == (1, 2)


@pytest.mark.slow
def test_alexnet_layers_and_pretrained_loading(tmp_path):
    torch.manual_seed(0)
    ref = AlexNet(n_classes=1000)
    convs = [m for m in ref.features if isinstance(m, torch.nn.Conv2d)]
    fcs = [m for m in ref.classifier if isinstance(m, torch.nn.Linear)]
    assert len(convs) == 5 and len(fcs) == 3
    path = tmp_path / "alexnet.pth"
    torch.save(ref.state_dict(), path)  # torchvision's parameter names and shapes
    from microdoppler.classifier.models import build_model

    m = build_model("alexnet", alexnet_weights=str(path))
    for a, b in zip(m.features.parameters(), ref.features.parameters()):
        assert torch.equal(a, b) and not a.requires_grad
    assert all(p.requires_grad for p in m.classifier.parameters())
    assert m.classifier[-1].out_features == 2
    assert m(torch.zeros(2, 20, 480)).shape == (2, 2)
    assert m.to_rgb(torch.zeros(1, 20, 480)).shape == (1, 3, 224, 224)
    bad = tmp_path / "bad.pth"
    torch.save({"features.0.weight": torch.zeros(3)}, bad)
    with pytest.raises(InputError):
        build_model("alexnet", alexnet_weights=str(bad))


# --- training ------------------------------------------------------------------------

SETS = ("train",) * 3 + ("validation", "test")
TINY = TrainConfig(max_epochs=2, compact={"channels": [4, 8], "doppler_pool": 8})


@pytest.fixture(scope="module")
def tiny_tiles():
    ts = toy_tiles(80, seed=3, sets=SETS, n_bins=128, flight_tiles=2)
    parts = [ts.subset(ts.labels["set"] == s) for s in ("train", "validation", "test")]
    return parts


@pytest.mark.slow
def test_tiny_training_run_and_reproducibility(tiny_tiles, tmp_path):
    tr, va, te = tiny_tiles
    runs = [train(tr, va, TINY, seed=11, threads=1) for _ in range(2)]
    h = runs[0].history
    assert list(h["epoch"]) == [1, 2] and h["selected"].sum() == 1
    assert runs[0].best_epoch == int(h.loc[h["selected"], "epoch"].iloc[0])
    assert np.all(np.isfinite(h[["train_loss", "val_loss"]].to_numpy()))
    pd.testing.assert_frame_equal(h.drop(columns="seconds"), runs[1].history.drop(columns="seconds"))
    preds = [predictions_table(te, predict(r.model, te.images, TINY.normalisation)) for r in runs]
    np.testing.assert_equal(seed_metrics(preds[0]), seed_metrics(preds[1]))  # NaN == NaN here
    np.testing.assert_array_equal(preds[0]["p_drone"], preds[1]["p_drone"])
    # saved and reloaded model predicts the same
    save_model(tmp_path / "m.pt", runs[0], TINY, seed=11, trainset="real")
    model, cfg = load_model(tmp_path / "m.pt")
    np.testing.assert_array_equal(predict(model, te.images, cfg.normalisation), preds[0]["p_drone"])


def test_different_seeds_differ(tiny_tiles):
    tr, va, te = tiny_tiles
    a = train(tr, va, TINY, seed=1, threads=1).history
    b = train(tr, va, TINY, seed=2, threads=1).history
    assert not np.allclose(a["train_loss"], b["train_loss"])


def test_weight_averaging_keeps_the_mean_of_the_last_epochs(tiny_tiles):
    """average_last_epochs K: the kept weights are the element-wise mean of the last
    K epochs' weights (one run, one seed), and the history marks those epochs."""
    from dataclasses import replace

    from microdoppler.classifier.training import average_states

    tr, va, te = tiny_tiles
    cfg = replace(TINY, max_epochs=3, average_last_epochs=2)
    res = train(tr, va, cfg, seed=5, threads=1)
    assert list(res.history["selected"]) == [False, True, True]
    # the same run stopped after 2 and after 3 epochs gives the two states averaged
    s2 = train(tr, va, replace(cfg, max_epochs=2, average_last_epochs=1), seed=5, threads=1).model.state_dict()
    s3 = train(tr, va, replace(cfg, average_last_epochs=1), seed=5, threads=1).model.state_dict()
    want = average_states([s2, s3])
    for k, v in res.model.state_dict().items():
        torch.testing.assert_close(v, want[k])
        if torch.is_floating_point(v) and not torch.equal(s2[k], s3[k]):
            assert not torch.equal(v, s3[k])
    with pytest.raises(InputError):
        TrainConfig(average_last_epochs=-1)


@pytest.mark.slow
def test_evaluation_in_forward_chunks_gives_the_same_loss_and_accuracy():
    """_evaluate runs the forward pass in chunks of EVAL_FORWARD_BATCH images: the
    logits, hence the loss summed per block and the accuracy, equal one forward pass
    per block (the speed-up must not change the history or the stopping rule)."""
    from torch.nn import functional as F

    from microdoppler.classifier.training import EVAL_FORWARD_BATCH, _evaluate

    ts = toy_tiles(300, seed=8, n_bins=480)
    x, y = torch.from_numpy(Normalisation()(ts.images)), torch.from_numpy(ts.y)
    torch.manual_seed(4)
    model = CompactCNN().eval()
    assert len(x) % EVAL_FORWARD_BATCH and len(x) > 256  # ragged chunks and blocks
    loss, correct = 0.0, 0
    with torch.no_grad():
        for i in range(0, len(x), 256):
            logits = model(x[i : i + 256])
            loss += F.cross_entropy(logits, y[i : i + 256], reduction="sum").item()
            correct += (logits.argmax(1) == y[i : i + 256]).sum().item()
    assert _evaluate(model, x, y, 256) == (loss / len(x), correct / len(x))
    assert np.isnan(_evaluate(model, x[:0], y[:0], 256)[0])


def test_config_validation():
    with pytest.raises(InputError):
        TrainConfig(learning_rate=0)
    with pytest.raises(InputError):
        TrainConfig(momentum=1.0)
    cfg = TrainConfig.from_config({"max_epochs": 3, "normalisation": {"scale_db": 10.0}, "seeds": [1]})
    assert cfg.max_epochs == 3 and cfg.normalisation.scale_db == 10.0


# --- tile stores, training-set recipe and reports -----------------------------------


def test_trainset_replaces_large_drones(tmp_path):
    real = toy_tiles(60, seed=4, sets=SETS, n_bins=64, flight_tiles=2)
    twin = toy_tiles(60, seed=9, sets=SETS, n_bins=64, flight_tiles=2)
    twin = twin.subset(twin.labels.drone_model.isin(["inspire2", "matrice300"]).to_numpy())  # a twin store
    write_tiles(tmp_path / "real.zarr", real)
    write_tiles(tmp_path / "sub_cpi.zarr", twin)
    back = read_tiles(tmp_path / "real.zarr")
    np.testing.assert_array_equal(back.images, real.images)
    tr, va, te = load_trainset("sub_cpi", tmp_path)
    large = ("inspire2", "matrice300")
    # large drones come from the twin store, everything else from the measured one
    got = tr.images[tr.labels.drone_model.isin(large).to_numpy()]
    want = twin.images[(twin.labels.set == "train").to_numpy() & twin.labels.drone_model.isin(large).to_numpy()]
    np.testing.assert_array_equal(got, want)
    assert set(tr.labels.set) == {"train"} and set(va.labels.set) == {"validation"}
    np.testing.assert_array_equal(te.images, real.images[(real.labels.set == "test").to_numpy()])
    with pytest.raises(InputError):
        read_tiles(tmp_path / "missing.zarr")


def _fake_predictions(rng, trainsets, seeds, n=60, per_flight=6):
    """Predictions of every (trainset, seed) on one test set of n images, per_flight
    images per flight (one class and model per flight)."""
    target = np.repeat(np.array(["bird", "drone"] * (n // (2 * per_flight))), per_flight)
    flight = np.repeat([f"f{i:02d}" for i in range(n // per_flight)], per_flight)
    model = np.repeat(
        np.where(np.arange(n // per_flight) % 2, rng.choice(["inspire2", "mini2"], n // per_flight), ""), per_flight
    )
    radar = np.repeat(rng.choice(["1", "2"], n // per_flight), per_flight)
    out = {}
    for t in trainsets:
        for s in seeds:
            pred = np.where(rng.random(n) < 0.85, target, np.where(target == "bird", "drone", "bird"))
            out[(t, s)] = pd.DataFrame(
                {"flight_id": flight, "target": target, "drone_model": model, "predicted": pred, "radar_id": radar}
            )
    return out


def test_table_v_and_extended_gain(rng, tmp_path):
    preds = _fake_predictions(rng, ["sub_cpi", "real", "extended"], [1, 2, 3])
    paths = write_reports(preds, tmp_path)
    metrics = pd.read_csv(paths["metrics"])
    assert list(metrics["trainset"].unique()) == ["real", "sub_cpi", "extended"]
    tv = table_v(metrics, preds, n_boot=300)
    on_disk = pd.read_csv(paths["table_v"])
    assert {"accuracy_ci95_low", "accuracy_ci95_high"} <= set(on_disk.columns)
    assert {"sub_cpi - real", "extended - real", "extended - sub_cpi"} <= set(on_disk["trainset"])
    real = tv.set_index("trainset").loc["real"]
    assert real["accuracy_ci95_low"] < real["accuracy_mean"] < real["accuracy_ci95_high"]
    acc = 100 * metrics.loc[metrics.trainset == "real", "accuracy"]
    assert real["accuracy_mean"] == pytest.approx(acc.mean())
    assert real["accuracy_std"] == pytest.approx(acc.std(ddof=1))
    assert real["paper_accuracy"] == "89.7 ± 0.5"
    gain = tv.set_index("trainset").loc["extended - sub_cpi"]
    d = 100 * (
        metrics[metrics.trainset == "extended"].set_index("seed")["drone_recall"]
        - metrics[metrics.trainset == "sub_cpi"].set_index("seed")["drone_recall"]
    )
    assert gain["drone_recall_mean"] == pytest.approx(d.mean())
    for name in ("fig12", "confusion_real"):
        assert paths[name].exists()
    cm = pd.read_csv(tmp_path / "confusion_real.csv")
    assert cm[["predicted_bird", "predicted_drone"]].to_numpy().sum() == pytest.approx(60)


def test_real_trainset_is_measured_train_and_validation(tmp_path):
    """``real`` = the measured train and validation tiles; test = the measured test tiles."""
    real = toy_tiles(60, seed=4, sets=SETS, n_bins=64, flight_tiles=2)
    write_tiles(tmp_path / "real.zarr", real)
    for got, s in zip(load_trainset("real", tmp_path), ("train", "validation", "test")):
        want = real.subset((real.labels.set == s).to_numpy())
        assert sorted(map(bytes, got.images)) == sorted(map(bytes, want.images))
        np.testing.assert_array_equal(np.sort(got.y), np.sort(want.y))


def test_training_without_validation_tiles(tiny_tiles):
    tr, va, _ = tiny_tiles
    res = train(tr, va.subset(np.zeros(len(va), bool)), TINY, seed=3, threads=1)
    assert res.history["val_loss"].isna().all()
    assert res.best_epoch == 1 + best_epoch(res.history["train_accuracy"], res.history["val_accuracy"])
    assert best_epoch([0.5, 0.9], [np.nan, np.nan]) == 1


# --- augmentation ----------------------------------------------------------------------


def _line_tiles(b=3, t=4, d=201, at=150):
    x = torch.zeros(b, t, d)
    x[:, :, at] = 1.0
    return x


def test_doppler_blur_spreads_a_line_by_its_sigma_and_keeps_its_sum():
    from microdoppler.classifier.augment import blur_doppler

    x = _line_tiles()
    y = blur_doppler(x, torch.tensor([0.0, 2.0, 5.0]))
    assert torch.equal(y[0], x[0])  # sigma 0: unchanged
    bins = torch.arange(x.shape[-1], dtype=torch.float32)
    for i, s in ((1, 2.0), (2, 5.0)):
        p = y[i, 0]
        torch.testing.assert_close(p.sum(), torch.tensor(1.0))  # a line away from the edges keeps its sum
        mean = (p * bins).sum()
        sd = ((p * (bins - mean) ** 2).sum()).sqrt()
        assert abs(float(mean) - 150) < 1e-3 and abs(float(sd) - s) < 0.05 * s
        assert torch.equal(y[i, 0], y[i, 3])  # the same kernel on every timestep of an image


def test_doppler_stretch_moves_lines_proportionally_about_zero_doppler():
    from microdoppler.classifier.augment import stretch_doppler

    d, c = 201, 100
    x = _line_tiles(b=2, d=d, at=c + 40)
    y = stretch_doppler(x, torch.tensor([1.0, 1.25]))
    torch.testing.assert_close(y[0], x[0])
    assert int(y[1, 0].argmax()) == c + 50  # 40 bins out, 25 % faster: 50 bins out
    x2 = _line_tiles(b=1, d=d, at=c - 40)
    assert int(stretch_doppler(x2, torch.tensor([0.75]))[0, 0].argmax()) == c - 30  # negative Doppler too


def test_doppler_wander_moves_a_line_along_time():
    from microdoppler.classifier.augment import Augmentation, stretch_doppler

    d, c = 201, 100
    x = _line_tiles(b=1, d=d, at=c + 40)
    t = x.shape[1]
    # a factor per timestep: the line sits at 40 * factor bins from zero Doppler in each
    fac = torch.linspace(0.9, 1.1, t)[None, :]
    y = stretch_doppler(x, fac)
    got = y[0].argmax(dim=1).numpy() - c
    np.testing.assert_allclose(got, 40 * fac[0].numpy(), atol=1.0)
    assert got[-1] - got[0] >= 7  # it moves: 36 -> 44 bins
    # the augmentation draws such a wandering factor; probability 1 and w > 0 move it
    gen = torch.Generator().manual_seed(5)
    moved = Augmentation(doppler_wander=0.2, probability=1.0)(x.repeat(8, 1, 1), gen).argmax(dim=2)
    assert (moved.max(dim=1).values - moved.min(dim=1).values).max() >= 2


def test_augmented_training_is_reproducible_and_differs_from_plain(tiny_tiles):
    from dataclasses import replace

    from microdoppler.classifier import Augmentation

    tr, va, _ = tiny_tiles
    cfg = replace(TINY, augment=Augmentation(doppler_blur_bins=3.0, doppler_stretch=0.1, probability=0.5))
    a = train(tr, va, cfg, seed=3, threads=1).history
    b = train(tr, va, cfg, seed=3, threads=1).history
    plain = train(tr, va, TINY, seed=3, threads=1).history
    pd.testing.assert_frame_equal(a.drop(columns="seconds"), b.drop(columns="seconds"))
    assert not np.allclose(a["train_loss"], plain["train_loss"])
    # off (any transform at 0, or probability 0) draws nothing: the plain run, bit for bit
    off = replace(TINY, augment=Augmentation(doppler_blur_bins=3.0, probability=0.0))
    pd.testing.assert_frame_equal(
        train(tr, va, off, seed=3, threads=1).history.drop(columns="seconds"), plain.drop(columns="seconds")
    )


def test_augmentation_config_errors_name_the_field():
    from microdoppler.classifier import Augmentation

    for bad in (
        {"doppler_blur_bins": -1.0},
        {"doppler_stretch": 0.5},
        {"probability": float("nan")},
        {"doppler_wander": -0.1},
        {"doppler_wander": 0.5},
    ):
        with pytest.raises(InputError, match=next(iter(bad))):
            Augmentation(**bad)
    cfg = TrainConfig.from_config({"augment": {"doppler_blur_bins": 2.0}})
    assert cfg.augment.doppler_blur_bins == 2.0 and cfg.augment.active
    assert cfg.to_dict()["augment"] == {
        "doppler_blur_bins": 2.0,
        "doppler_stretch": 0.0,
        "doppler_wander": 0.0,
        "probability": 0.5,
    }
    assert TrainConfig.from_config({"augment": {"doppler_wander": 0.05}}).augment.active
    assert not TrainConfig().augment.active
