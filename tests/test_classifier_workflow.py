"""A small real run of the classifier rules (train, evaluate, report) with Snakemake."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
import yaml

from microdoppler.classifier.data import toy_tiles, write_tiles

ROOT = Path(__file__).resolve().parents[1]
SETS = ("train",) * 3 + ("validation", "test")

pytestmark = pytest.mark.skipif(
    shutil.which("snakemake") is None and not Path(sys.executable).with_name("snakemake").exists(),
    reason="snakemake not installed",
)


@pytest.mark.slow
def test_classifier_rules_end_to_end(tmp_path):
    cfg = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    cfg["classifier"].update(
        trainsets=["real", "sub_cpi"],
        seeds=[1],
        max_epochs=1,
        compact={"channels": [4, 8], "doppler_pool": 8, "dropout": 0.0},
    )
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(cfg))
    (tmp_path / "Snakefile").write_text(
        'configfile: "config.yaml"\n'
        f'include: "{ROOT}/workflow/rules/common.smk"\n'
        f'include: "{ROOT}/workflow/rules/classifier.smk"\n'
        f'report: "{ROOT}/workflow/report/workflow.rst"\n'
        "rule all:\n    input: classifier_targets()\n    default_target: True\n"
    )
    real = toy_tiles(60, seed=2, sets=SETS, n_bins=64, flight_tiles=2)
    twin = toy_tiles(60, seed=8, sets=SETS, n_bins=64, flight_tiles=2)
    write_tiles(tmp_path / "results/tiles/real.zarr", real)
    write_tiles(
        tmp_path / "results/tiles/sub_cpi.zarr",
        twin.subset(twin.labels.drone_model.isin(["inspire2", "matrice300"]).to_numpy()),
    )
    snakemake = str(Path(sys.executable).with_name("snakemake"))
    run = subprocess.run([snakemake, "--cores", "2", "-q"], cwd=tmp_path, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    rep = tmp_path / "results/reports"
    metrics = pd.read_csv(rep / "metrics.csv")
    assert len(metrics) == 2 and set(metrics.trainset) == {"real", "sub_cpi"}
    assert metrics[["accuracy", "drone_recall", "bird_recall"]].apply(lambda c: c.between(0, 1)).all().all()
    tv = pd.read_csv(rep / "table_v.csv")
    assert list(tv.trainset) == ["real", "sub_cpi", "sub_cpi - real"] and (tv.n_seeds == 1).all()
    assert tv[["accuracy_ci95_low", "accuracy_ci95_high"]].notna().all().all()
    pred = pd.read_csv(tmp_path / "results/eval/real/seed1.csv", keep_default_na=False)
    assert len(pred) == int((real.labels.set == "test").sum())
    for name in ("fig12_boxplot.png", "confusion_real.png", "confusion_sub_cpi.csv"):
        assert (rep / name).stat().st_size > 0
    log = (tmp_path / "results/logs/train_classifier/real.log").read_text()  # a training set per job
    # config default average_last_epochs: 4 (the paper kept the best epoch)
    assert "epoch   1" in log and "kept the average of the weights of epochs" in log
    report = subprocess.run([snakemake, "--report", "report.html"], cwd=tmp_path, capture_output=True, text=True)
    assert report.returncode == 0, report.stderr[-3000:]
    assert (tmp_path / "report.html").stat().st_size > 0
