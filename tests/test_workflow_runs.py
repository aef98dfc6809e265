"""A run killed with SIGKILL part-way recovers with ``snakemake --unlock`` and the same
command again, no further flags (the default workflow profile, profiles/default,
reruns the jobs left incomplete), and its results equal an uninterrupted run's.

Both runs are CI's small real target (``--configfile config/test.yaml``) in the same
temporary working directory (the finished reference is moved aside first: some
outputs record absolute paths of their inputs), never in the repository's results/.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[1]
SNAKEMAKE = shutil.which("snakemake") or str(Path(sys.executable).with_name("snakemake"))
#: CI's environment (.ci/run)
ENV = {**os.environ, "PYTHONHASHSEED": "0", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "MPLBACKEND": "Agg"}
#: wall-clock timings written into outputs (the only values allowed to differ):
#: CSV columns and JSON keys (also Zarr attributes) of these names
TIMINGS = {"seconds", "fit_seconds"}
#: compared as a file list only: logs (timestamps) and benchmarks (timings)
LISTED_ONLY = ("results/logs/", "results/benchmarks/")


def command(work, *args):
    """What a user types in ``work`` (plus -s/-d: the workflow is the repository's)."""
    return [SNAKEMAKE, "-s", str(REPO / "Snakefile"), "-d", str(work), *args]


RUN = ("--cores", "2", "--configfile", "config/test.yaml")


def new_workdir(root: Path) -> Path:
    """``root/run``, seeing config/ and figures.ulog as a run in the repository does
    (``../shared`` beside it, as in CI)."""
    work = root / "run"
    work.mkdir()
    (work / "config").symlink_to(REPO / "config")
    ulog = Path(yaml.safe_load((REPO / "config/config.yaml").read_text())["figures"]["ulog"])
    if not ulog.is_absolute():
        top = 2 if ulog.parts[0] == ".." else 1
        link = work.joinpath(*ulog.parts[:top])
        if not link.exists():
            link.symlink_to(REPO.joinpath(*ulog.parts[:top]).resolve())
    return work


def run(work, *args, log: Path):
    with open(log, "w") as fh:
        return subprocess.run(command(work, *args), cwd=work, env=ENV, stdout=fh, stderr=subprocess.STDOUT,
                              timeout=900).returncode


def run_and_kill(work, log: Path, started: str, outputs) -> int:
    """Start the run; once ``started`` (a glob under ``work``: a job's log) appears,
    stop Snakemake (SIGSTOP, its jobs go on), wait for ``outputs(log)`` of that job to
    exist, then SIGKILL the whole process group (Snakemake and its jobs): the moment
    after a job wrote its outputs and before Snakemake recorded it as finished, so its
    complete-looking outputs are still marked incomplete, while other jobs are cut off
    part-way. Returns the run's return code."""
    with open(log, "w") as fh:
        proc = subprocess.Popen(command(work, *RUN), cwd=work, env=ENV, stdout=fh, stderr=subprocess.STDOUT,
                                start_new_session=True)
        try:
            deadline = time.monotonic() + 900
            while not (hit := sorted(work.glob(started))):
                assert proc.poll() is None, f"the run ended (rc {proc.returncode}) before {started} appeared"
                assert time.monotonic() < deadline, f"{started} did not appear"
                time.sleep(0.05)
            os.kill(proc.pid, signal.SIGSTOP)
            wanted = [work / p for p in outputs(hit[0].relative_to(work))]
            while not all(p.exists() for p in wanted):
                assert time.monotonic() < deadline, f"{wanted} did not appear"
                time.sleep(0.05)
        finally:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    for _ in range(100):  # the jobs die with Snakemake: nothing may write on
        try:
            os.killpg(proc.pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.1)
    else:
        pytest.fail("processes of the killed run survived SIGKILL")
    return proc.returncode


def training_outputs(log: Path) -> list[str]:
    """results/logs/train_classifier/{trainset}_seed{seed}.log -> that job's outputs."""
    trainset, seed = log.stem.rsplit("_seed", 1)
    return [f"results/models/{trainset}/seed{seed}.pt", f"results/models/{trainset}/seed{seed}_history.csv"]


def _drop_timings(obj):
    if isinstance(obj, dict):
        return {k: _drop_timings(v) for k, v in obj.items() if k not in TIMINGS}
    if isinstance(obj, list):
        return [_drop_timings(v) for v in obj]
    return obj


def fingerprint(path: Path) -> str:
    """sha256 of the bytes, with timings blanked (CSV, JSON); models (.pt) by bytes too."""
    data = path.read_bytes()
    if path.suffix == ".csv":
        rows = list(csv.reader(io.StringIO(data.decode())))
        if rows and TIMINGS & set(rows[0]):
            keep = [i for i, c in enumerate(rows[0]) if c not in TIMINGS]
            data = json.dumps([[r[i] for i in keep] for r in rows]).encode()
    elif path.suffix == ".json":
        obj = json.loads(data)
        stripped = _drop_timings(obj)
        if stripped != obj:
            data = json.dumps(stripped, sort_keys=True).encode()
    return hashlib.sha256(data).hexdigest()


def results(work: Path) -> dict:
    """Every file under results/: its fingerprint (None for LISTED_ONLY files)."""
    out = {}
    for p in sorted((work / "results").rglob("*")):
        if p.is_file():
            rel = p.relative_to(work).as_posix()
            out[rel] = None if rel.startswith(LISTED_ONLY) else fingerprint(p)
    return out


@pytest.mark.slow
def test_killed_run_recovers_with_unlock_and_gives_the_same_results(tmp_path):
    ulog = yaml.safe_load((REPO / "config/config.yaml").read_text())["figures"]["ulog"]
    if not (REPO / ulog).is_file():  # an input of the run: a failure, not a skip (as in conftest)
        pytest.fail(f"the PX4 log for Fig. 2c (figures.ulog: {ulog}) is not there: expected "
                    f"{(REPO / ulog).resolve()}", pytrace=False)

    # 1. uninterrupted reference, then moved aside (the same path is reused below)
    work = new_workdir(tmp_path)
    assert run(work, *RUN, log=tmp_path / "reference.log") == 0, (tmp_path / "reference.log").read_text()[-3000:]
    reference = results(work)
    work.rename(tmp_path / "reference")

    # 2. the same run, killed once the first classifier job has written its outputs
    work = new_workdir(tmp_path)
    rc = run_and_kill(work, tmp_path / "killed.log", "results/logs/train_classifier/*.log", training_outputs)
    assert rc == -signal.SIGKILL
    assert not (work / "results/reports/metrics.csv").exists()
    # without the workflow profile Snakemake stops at the incomplete outputs
    no_profile = tmp_path / "no_profile.log"
    assert run(work, *RUN, "-n", "--workflow-profile", "none", log=no_profile) != 0
    assert "IncompleteFilesException" in no_profile.read_text(), no_profile.read_text()[-3000:]

    # 3. what the README says: unlock, then the same command again
    assert run(work, "--unlock", log=tmp_path / "unlock.log") == 0, (tmp_path / "unlock.log").read_text()
    rerun_log = tmp_path / "rerun.log"
    assert run(work, *RUN, log=rerun_log) == 0, rerun_log.read_text()[-3000:]
    text = rerun_log.read_text()
    assert "workflow specific profile" in text and "profiles/default" in text
    assert run(work, *RUN, "-n", log=tmp_path / "after.log") == 0
    assert "Nothing to be done" in (tmp_path / "after.log").read_text()

    # 4. the same files, with the same content (timings aside)
    recovered = results(work)
    assert sorted(recovered) == sorted(reference), (
        f"only after the kill: {sorted(set(recovered) - set(reference))}; "
        f"only in the reference: {sorted(set(reference) - set(recovered))}")
    differ = [f for f in reference if recovered[f] != reference[f]]
    assert not differ, f"differ from the uninterrupted run: {differ}"
    for f in ("results/reports/metrics.csv", "results/reports/table_v.csv", "results/splits/flights.csv"):
        assert f in reference
