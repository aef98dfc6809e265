"""The dataset rules run for real on the tiny world, and editing one variant's
settings reruns only that variant's chain (``snakemake -n``)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
import yaml

from microdoppler.io.inventory import ingest_flight_logs

from test_datasets_world import make_world

REPO = Path(__file__).resolve().parents[1]
#: two Snakemake runs of the dataset rules (one flight batch, two): the whole suite only
pytestmark = pytest.mark.slow
#: the dataset stages of the real workflow (top-level Snakefile, common.smk, rules)
TARGETS = [
    "results/splits/flights.csv",
    "results/reports/table_iii.csv",
    "results/reports/table_iv.csv",
    "results/tiles/real.zarr",
    "results/tiles/sub_cpi.zarr",
    "results/tiles/fixed_speeds.zarr",
    "results/figures/twins_inspire2.png",
    "results/figures/twins_matrice300.png",
]


def snakemake(cwd, *args):
    exe = shutil.which("snakemake") or str(Path(sys.executable).with_name("snakemake"))
    cmd = [
        exe,
        *TARGETS,
        "--cores",
        "2",
        "-s",
        str(REPO / "Snakefile"),
        "-d",
        str(cwd),
        "--configfile",
        "config.yaml",
        *args,
    ]
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    wd = tmp_path_factory.mktemp("wf")
    make_world(wd / "results" / "measured", duration_s=7.0)
    ingest_flight_logs(
        wd / "results" / "measured",
        wd / "results/motors/logs.zarr",
        wd / "results/motors/ingest.csv",
        log=lambda m: None,
    )
    cfg = yaml.safe_load((REPO / "config/config.yaml").read_text())
    cfg["sampling"]["variants"] = ["sub_cpi", "fixed_speeds"]
    cfg["measurements"].update(source="directory", directory="results/measured")
    (wd / "config.yaml").write_text(yaml.safe_dump(cfg))
    r = snakemake(wd, "-q", "progress")
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return wd


def test_dataset_rules_produce_the_contract_files(workdir):
    res = workdir / "results"
    split = pd.read_csv(res / "splits/flights.csv")
    assert list(split.columns) == ["flight_id", "set", "target", "drone_model", "radar_id"]
    for f in [
        "reports/table_iii.csv",
        "reports/table_iv.csv",
        "reports/table_iv_sub_cpi.csv",
        "figures/twins_inspire2.png",
        "figures/twins_matrice300.png",
    ]:
        assert (res / f).stat().st_size > 0, f
    for d in ["real", "sub_cpi", "fixed_speeds"]:
        assert (res / "tiles" / f"{d}.zarr" / "labels.csv").exists()
        assert (res / "benchmarks/tile_spectrograms" / f"{d}.tsv").exists()
    for rule in ["resample_motor_speeds", "synthesize_flights", "inject_background"]:
        assert (res / "benchmarks" / rule / "sub_cpi.tsv").exists()
    t4 = pd.read_csv(res / "reports/table_iv_fixed_speeds.csv")
    assert (t4.status.isin(["ok", "skipped: no motor log"])).all()


def test_editing_one_variant_reruns_only_its_chain(workdir):
    cfg = yaml.safe_load((workdir / "config.yaml").read_text())
    cfg["sampling"]["per_variant"]["sub_cpi"]["window_pulses_max"] = 2900
    (workdir / "config.yaml").write_text(yaml.safe_dump(cfg))
    try:
        r = snakemake(workdir, "-n")
        assert r.returncode == 0, r.stderr[-2000:]
        out = r.stdout + r.stderr
        assert "variant=sub_cpi" in out and "dataset=sub_cpi" in out
        assert "variant=fixed_speeds" not in out and "dataset=fixed_speeds" not in out
        assert "dataset=real" not in out and "rule split_flights" not in out
    finally:
        cfg["sampling"]["per_variant"]["sub_cpi"]["window_pulses_max"] = 3000
        (workdir / "config.yaml").write_text(yaml.safe_dump(cfg))
    r = snakemake(workdir, "-n")
    assert "Nothing to be done" in r.stdout + r.stderr


# --- flight batches (datasets.flight_batches, issue 11 §4) ---
BATCH_VARIANTS = ["sub_cpi", "fixed_speeds"]


def _groups(path) -> dict:
    """{flight id: (attrs without the fit's run time, iq bytes)} of a twin store."""
    import zarr

    root = zarr.open_group(str(path), mode="r")
    out = {}
    for fid, g in root.groups():
        attrs = dict(g.attrs)
        attrs["calibration"] = {k: v for k, v in attrs["calibration"].items() if k != "fit_seconds"}
        out[fid] = (attrs, g["iq"][...].tobytes())
    return out


@pytest.fixture(scope="module")
def batched(workdir, tmp_path_factory):
    """The same world and config with datasets.flight_batches = 2."""
    wd = tmp_path_factory.mktemp("wf_batched")
    shutil.copytree(workdir / "results/measured", wd / "results/measured")
    shutil.copytree(workdir / "results/motors", wd / "results/motors")
    cfg = yaml.safe_load((workdir / "config.yaml").read_text())
    cfg["datasets"]["flight_batches"] = 2
    (wd / "config.yaml").write_text(yaml.safe_dump(cfg))
    exe = shutil.which("snakemake") or str(Path(sys.executable).with_name("snakemake"))
    targets = [f"results/{kind}/{v}.zarr" for kind in ("tiles", "injected") for v in BATCH_VARIANTS]
    targets += [f"results/reports/table_iv_{v}.csv" for v in BATCH_VARIANTS]
    r = subprocess.run(
        [
            exe,
            *targets,
            "--cores",
            "2",
            "-s",
            str(REPO / "Snakefile"),
            "-d",
            str(wd),
            "--configfile",
            "config.yaml",
            "-q",
            "progress",
        ],
        cwd=wd,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    return wd


@pytest.mark.parametrize("variant", BATCH_VARIANTS)
def test_two_flight_batches_give_the_same_twins_and_tiles(workdir, batched, variant):
    from microdoppler.datasets.batches import flight_batch

    one, two = workdir / "results", batched / "results"
    twins = _groups(one / f"synthetic/{variant}.zarr")
    parts = [_groups(two / f"synthetic/{variant}/batch{b}.zarr") for b in range(2)]
    # each batch holds exactly its flights (both non-empty in this world), every twin as with one batch
    assert all(parts) and sorted(twins) == sorted(f for p in parts for f in p)
    for b, part in enumerate(parts):
        assert {flight_batch(f, 2) for f in part} == {b}
        assert all(part[f] == twins[f] for f in part)
    assert (two / f"benchmarks/synthesize_flights/{variant}/batch1.tsv").exists()
    assert (two / f"benchmarks/inject_background/{variant}/batch0.tsv").exists()
    # the merged injected store and the tiles equal those of one job per variant
    assert _groups(two / f"injected/{variant}.zarr") == _groups(one / f"injected/{variant}.zarr")
    import zarr

    a = zarr.open_group(str(one / f"tiles/{variant}.zarr"), mode="r")
    b = zarr.open_group(str(two / f"tiles/{variant}.zarr"), mode="r")
    assert a["images"].shape[0] > 0 and a["images"][...].tobytes() == b["images"][...].tobytes()
    labels = [(d / f"tiles/{variant}.zarr/labels.csv").read_bytes() for d in (one, two)]
    assert labels[0] == labels[1]
    # Table IV: same rows in the same order (the fit's run time aside)
    t1 = pd.read_csv(one / f"reports/table_iv_{variant}.csv").drop(columns="fit_seconds")
    t2 = pd.read_csv(two / f"reports/table_iv_{variant}.csv").drop(columns="fit_seconds")
    pd.testing.assert_frame_equal(t1, t2)
