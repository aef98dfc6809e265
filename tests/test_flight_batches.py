"""Flight batches of the per-flight dataset stages (``datasets.flight_batches``):
stable batch assignment, merging of batch stores and tables, and the job layout
(``snakemake -n``). That N = 2 gives the same twins and tiles as N = 1 is
``test_datasets_workflow.py::test_two_flight_batches_give_the_same_twins_and_tiles``."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import zarr

from microdoppler.datasets.batches import batch_filter, flight_batch, merge_stores, merge_tables
from microdoppler.datasets.injection import INJECTED_SCHEMA
from microdoppler.datasets.speeds import SPEEDS_SCHEMA
from microdoppler.datasets.stores import put_array, writing_store
from microdoppler.errors import InputError

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_flight_batch_is_stable_and_balanced():
    ids = [f"flight_{i:04d}" for i in range(600)]
    got = [flight_batch(f, 4) for f in ids]
    # CRC32 of the id: the same in every process (no PYTHONHASHSEED dependence)
    assert got[:6] == [flight_batch(f, 4) for f in ids[:6]]
    out = subprocess.run(
        [
            sys.executable,
            "-c",
            "from microdoppler.datasets.batches import flight_batch;"
            "print([flight_batch(f'flight_{i:04d}', 4) for i in range(600)])",
        ],
        capture_output=True,
        text=True,
        env={"PYTHONHASHSEED": "123", "PATH": ""},
        check=True,
    )
    assert out.stdout.strip() == str(got)
    counts = Counter(got)
    assert set(counts) == {0, 1, 2, 3}
    assert max(counts.values()) - min(counts.values()) < 0.2 * 150, counts
    assert all(flight_batch(f, 1) == 0 for f in ids)
    assert [f for f in ids if batch_filter(2, 4)(f)] == [f for f, b in zip(ids, got) if b == 2]
    with pytest.raises(InputError, match="flight_batches"):
        flight_batch("x", 0)
    with pytest.raises(InputError, match="batch"):
        batch_filter(4, 4)


def _store(path, flights, variant="v"):
    with writing_store(path, {"schema": INJECTED_SCHEMA, "variant": variant, "target_only": True}) as root:
        for fid in flights:
            g = root.require_group(fid)
            g.attrs["twin_of"] = fid
            put_array(g, "iq", (np.arange(5) + len(fid) * 1j).astype(np.complex64))


def test_merge_stores_is_the_union_and_refuses_duplicates(tmp_path):
    _store(tmp_path / "all.zarr", ["a", "b", "c"])
    _store(tmp_path / "b0.zarr", ["b"])
    _store(tmp_path / "b1.zarr", ["a", "c"])
    got = merge_stores(
        [tmp_path / "b0.zarr", tmp_path / "b1.zarr"], tmp_path / "m.zarr", INJECTED_SCHEMA, log=lambda m: None
    )
    assert got == ["a", "b", "c"]
    a, m = (zarr.open_group(str(tmp_path / n), mode="r") for n in ("all.zarr", "m.zarr"))
    assert dict(a.attrs) == dict(m.attrs)
    for fid in got:
        assert dict(m[fid].attrs) == dict(a[fid].attrs)
        assert m[fid]["iq"][...].tobytes() == a[fid]["iq"][...].tobytes()
    _store(tmp_path / "empty.zarr", [])
    merge_stores(
        [tmp_path / "b0.zarr", tmp_path / "empty.zarr", tmp_path / "b1.zarr"],
        tmp_path / "m1.zarr",
        INJECTED_SCHEMA,
        log=lambda m: None,
    )
    assert sorted(n for n, _ in zarr.open_group(str(tmp_path / "m1.zarr"), mode="r").groups()) == got
    _store(tmp_path / "dup.zarr", ["c"])
    with pytest.raises(InputError, match="also in"):
        merge_stores([tmp_path / "b1.zarr", tmp_path / "dup.zarr"], tmp_path / "m2.zarr", INJECTED_SCHEMA)
    _store(tmp_path / "other.zarr", ["d"], variant="w")
    with pytest.raises(InputError, match="attrs"):
        merge_stores([tmp_path / "b0.zarr", tmp_path / "other.zarr"], tmp_path / "m3.zarr", INJECTED_SCHEMA)
    assert not (tmp_path / "m2.zarr").exists() and not (tmp_path / "m3.zarr").exists()


def test_merge_tables_restores_the_one_job_order(tmp_path):
    with writing_store(tmp_path / "speeds.zarr", {"schema": SPEEDS_SCHEMA, "skipped": {"z": "no motor log"}}) as root:
        for fid in ["a", "b", "c"]:
            root.require_group(fid)
    pd.DataFrame({"flight_id": ["c", "a"], "status": ["ok", "ok"], "n": [3, 1]}).to_csv(
        tmp_path / "t0.csv", index=False
    )
    pd.DataFrame({"flight_id": ["z", "b"], "status": ["skipped: no motor log", "ok"], "n": [np.nan, 2]}).to_csv(
        tmp_path / "t1.csv", index=False
    )
    df = merge_tables(
        [tmp_path / "t0.csv", tmp_path / "t1.csv"], tmp_path / "speeds.zarr", tmp_path / "t.csv", log=lambda m: None
    )
    assert list(df.flight_id) == ["z", "a", "b", "c"]
    assert list(pd.read_csv(tmp_path / "t.csv").flight_id) == ["z", "a", "b", "c"]
    # an empty batch (more batches than flights) changes neither rows nor number formats
    pd.DataFrame(columns=["flight_id", "status", "n"]).to_csv(tmp_path / "t2.csv", index=False)
    merge_tables(
        [tmp_path / "t2.csv", tmp_path / "t0.csv", tmp_path / "t1.csv"],
        tmp_path / "speeds.zarr",
        tmp_path / "t3.csv",
        log=lambda m: None,
    )
    assert (tmp_path / "t3.csv").read_bytes() == (tmp_path / "t.csv").read_bytes()
    assert "3.0" in (tmp_path / "t.csv").read_text()  # n has a NaN row: floats, as one job writes it
    with pytest.raises(InputError, match="misses"):
        merge_tables([tmp_path / "t0.csv"], tmp_path / "speeds.zarr", tmp_path / "u.csv")


def _dry_run(tmp_path, n_batches):
    (tmp_path / "batches.yaml").write_text(f"datasets:\n  flight_batches: {n_batches}\n")
    exe = shutil.which("snakemake") or str(Path(sys.executable).with_name("snakemake"))
    # the dataset products (the whole default target also needs ../shared, relative to the repository)
    targets = [
        "results/reports/table_iv.csv",
        "results/tiles/sub_cpi.zarr",
        "results/tiles/fixed_speeds.zarr",
        "results/figures/twins_inspire2.png",
    ]
    r = subprocess.run(
        [
            exe,
            *targets,
            "-n",
            "-s",
            str(REPO / "Snakefile"),
            "-d",
            str(tmp_path),
            "--configfile",
            str(REPO / "config/test.yaml"),
            str(tmp_path / "batches.yaml"),
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    out = r.stdout + r.stderr
    jobs = re.findall(r"^(?:local)?rule (\w+):\n(?:    .*\n)*?    wildcards: ([^\n]*)", out, flags=re.M)
    return out, jobs


@pytest.mark.slow
def test_three_flight_batches_run_three_twin_and_injection_jobs_per_variant(tmp_path):
    out, jobs = _dry_run(tmp_path, 3)
    variants = ["sub_cpi", "fixed_speeds"]  # config/test.yaml
    for rule in ("synthesize_flights", "inject_background"):
        wcs = sorted(w for r, w in jobs if r == rule)
        assert wcs == sorted(f"variant={v}, batch={b}" for v in variants for b in range(3)), (rule, wcs)
        assert f"results/benchmarks/{rule}/sub_cpi/batch2.tsv" in out
    assert sorted(w for r, w in jobs if r == "merge_flight_batches") == sorted(f"variant={v}" for v in variants)
    assert "results/synthetic/sub_cpi/batch0.zarr" in out and "results/injected/fixed_speeds/batch2.zarr" in out


@pytest.mark.slow
def test_one_flight_batch_keeps_one_job_per_variant(tmp_path):
    out, jobs = _dry_run(tmp_path, 1)
    for rule in ("synthesize_flights", "inject_background"):
        assert sorted(w for r, w in jobs if r == rule) == ["variant=fixed_speeds", "variant=sub_cpi"]
    assert "merge_flight_batches" not in out and not re.search(r"/batch\d", out)
