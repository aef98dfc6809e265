"""Whole-workflow runs of CI's small real target (``--configfile config/test.yaml``),
narrowed further by :data:`TINY` (one sampling variant, one classifier seed, one epoch:
every rule of the default target still runs), each compared file by file:

- a run through ``--executor cluster-generic`` (profiles/local-cluster: every job its
  own process, started by the submit command) is the reference, run once per module;
- a local run killed with SIGKILL part-way recovers with ``snakemake --unlock`` and the
  same command again, no further flags (the default workflow profile, profiles/default,
  reruns the jobs left incomplete), and gives the same files as the cluster run.

A recovered local run equal to an uninterrupted cluster run shows both properties at
the cost of two runs (a third, uninterrupted local run would only repeat one of them).
Every run uses the same temporary working directory (a finished run is moved aside
first: some outputs record absolute paths of their inputs), never the repository's
results/.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import re
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
#: compared as a file list only: logs (timestamps), benchmarks and the per-rule times (timings)
LISTED_ONLY = ("results/logs/", "results/benchmarks/", "results/reports/rule_times.csv")


def command(work, *args):
    """What a user types in ``work`` (plus -s/-d: the workflow is the repository's)."""
    return [SNAKEMAKE, "-s", str(REPO / "Snakefile"), "-d", str(work), *args]


#: loaded on top of config/test.yaml: the smallest run in which every rule of the
#: default target still runs (and a train_classifier job for the killed run to stop at)
TINY = {"sampling": {"variants": ["sub_cpi"]}, "classifier": {"seeds": [1], "max_epochs": 1}}
CONFIG = ("--configfile", "config/test.yaml", "tiny.yaml")
RUN = ("--cores", "2", *CONFIG)


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
    (work / "tiny.yaml").write_text(yaml.safe_dump(TINY))
    return work


def run(work, *args, log: Path):
    with open(log, "w") as fh:
        return subprocess.run(
            command(work, *args), cwd=work, env=ENV, stdout=fh, stderr=subprocess.STDOUT, timeout=900
        ).returncode


def run_and_kill(work, log: Path, started: str, outputs) -> int:
    """Start the run; once ``started`` (a glob under ``work``: a job's log) appears,
    stop Snakemake (SIGSTOP, its jobs go on), wait for ``outputs(log)`` of that job to
    exist, then SIGKILL the whole process group (Snakemake and its jobs): the moment
    after a job wrote its outputs and before Snakemake recorded it as finished, so its
    complete-looking outputs are still marked incomplete, while other jobs are cut off
    part-way. Returns the run's return code."""
    with open(log, "w") as fh:
        proc = subprocess.Popen(
            command(work, *RUN), cwd=work, env=ENV, stdout=fh, stderr=subprocess.STDOUT, start_new_session=True
        )
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
    """results/logs/train_classifier/{trainset}.log -> that job's first seed's outputs."""
    trainset, seed = log.stem, TINY["classifier"]["seeds"][0]
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


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted run through the cluster-generic executor: (root, its results,
    its log's text); moved aside to root/cluster."""
    ulog = yaml.safe_load((REPO / "config/config.yaml").read_text())["figures"]["ulog"]
    if not (REPO / ulog).is_file():  # an input of the run: a failure, not a skip (as in conftest)
        pytest.fail(
            f"the PX4 log for Fig. 2c (figures.ulog: {ulog}) is not there: expected {(REPO / ulog).resolve()}",
            pytrace=False,
        )
    root = tmp_path_factory.mktemp("workflow")
    work = new_workdir(root)
    log = root / "cluster.log"
    # the profile as a user runs it; status checks every second instead of the default
    # 10 s (how soon Snakemake notices a finished job: nothing in the results depends on it)
    rc = run(
        work,
        "--profile",
        str(REPO / "profiles" / "local-cluster"),
        *CONFIG,
        "--seconds-between-status-checks",
        "1",
        log=log,
    )
    text = log.read_text()
    if rc != 0:
        pytest.fail(f"the cluster-generic run failed (rc {rc}):\n{text[-3000:]}", pytrace=False)
    ref = results(work)
    work.rename(root / "cluster")
    for f in (
        "results/reports/metrics.csv",
        "results/reports/table_v.csv",
        "results/splits/flights.csv",
        "results/diagnosis/report.json",
        "results/models/sub_cpi/seed1.pt",
    ):
        assert f in ref, f
    return root, ref, text


def assert_same_results(got: dict, reference: dict) -> None:
    assert sorted(got) == sorted(reference), (
        f"only in this run: {sorted(set(got) - set(reference))}; "
        f"only in the reference: {sorted(set(reference) - set(got))}"
    )
    differ = [f for f in reference if got[f] != reference[f]]
    assert not differ, f"differ from the uninterrupted cluster run: {differ}"


@pytest.mark.slow
def test_killed_run_recovers_with_unlock_and_gives_the_same_results(reference):
    root, ref, _ = reference
    # the same run, killed once the first classifier job has written its outputs
    work = new_workdir(root)
    try:
        rc = run_and_kill(work, root / "killed.log", "results/logs/train_classifier/*.log", training_outputs)
        assert rc == -signal.SIGKILL
        assert not (work / "results/reports/metrics.csv").exists()
        # without the workflow profile Snakemake stops at the incomplete outputs
        no_profile = root / "no_profile.log"
        assert run(work, *RUN, "-n", "--workflow-profile", "none", log=no_profile) != 0
        assert "IncompleteFilesException" in no_profile.read_text(), no_profile.read_text()[-3000:]

        # what the README says: unlock, then the same command again
        assert run(work, "--unlock", log=root / "unlock.log") == 0, (root / "unlock.log").read_text()
        rerun_log = root / "rerun.log"
        assert run(work, *RUN, log=rerun_log) == 0, rerun_log.read_text()[-3000:]
        text = rerun_log.read_text()
        assert "workflow specific profile" in text and "profiles/default" in text
        assert run(work, *RUN, "-n", log=root / "after.log") == 0
        assert "Nothing to be done" in (root / "after.log").read_text()

        # the same files, with the same content (timings aside)
        assert_same_results(results(work), ref)
    finally:
        work.rename(root / "killed")


@pytest.mark.slow
def test_cluster_generic_run_submits_every_job(reference):
    """Every job but the local target rule submitted through the cluster-generic executor
    as its own process (that its files equal a local run's: the killed-run test)."""
    _, ref, text = reference
    n_jobs = len(re.findall(r"with external jobid", text))
    n_rules = int(re.search(r"(\d+) of (\d+) steps \(100%\) done", text).group(2))
    assert n_jobs >= n_rules - 1, (n_jobs, n_rules)  # all but the local target rule were submitted
    assert n_rules >= 15 and len(ref) > n_rules, (n_rules, len(ref))


@pytest.mark.slow
def test_rule_times_table_has_every_rule_that_ran(reference):
    """results/reports/rule_times.csv: a row per rule that ran (every one has a
    benchmark: file), its jobs counted, and the ``all`` row their sum."""
    import pandas as pd

    root, _, text = reference
    table = pd.read_csv(root / "cluster" / "results/reports/rule_times.csv")
    jobs = re.findall(r"(?m)^rule (\w+):", text)
    ran = {r for r in jobs if r not in ("default", "all", "report_rule_times")}
    assert set(table.rule) == ran | {"all"}, set(table.rule) ^ (ran | {"all"})
    per_rule = table.set_index("rule")
    for r in ran:
        assert per_rule.loc[r, "jobs"] == jobs.count(r), r
    body = per_rule.drop(index="all")
    assert per_rule.loc["all", "jobs"] == body.jobs.sum()
    assert per_rule.loc["all", "total_s"] == pytest.approx(body.total_s.sum(), abs=0.01 * len(body))
    assert (body.total_s > 0).all() and (body.max_s <= body.total_s + 0.01).all()


@pytest.mark.slow
def test_classifier_reports_and_the_snakemake_report(reference):
    """The classifier's rules on the run's tiles (real and the one variant, one seed):
    metrics and Table V with its difference row and intervals, a prediction per test
    tile, the figures, a training set per job with the weights averaged (config
    ``average_last_epochs``); and ``snakemake --report`` of the whole run."""
    import pandas as pd

    from microdoppler.classifier.data import read_tiles

    root, _, _ = reference
    work = root / "cluster"
    rep = work / "results/reports"
    metrics = pd.read_csv(rep / "metrics.csv")
    assert len(metrics) == 2 and set(metrics.trainset) == {"real", "sub_cpi"}
    assert metrics[["accuracy", "drone_recall", "bird_recall"]].apply(lambda c: c.between(0, 1)).all().all()
    tv = pd.read_csv(rep / "table_v.csv")
    assert list(tv.trainset) == ["real", "sub_cpi", "sub_cpi - real"] and (tv.n_seeds == 1).all()
    assert tv[["accuracy_ci95_low", "accuracy_ci95_high"]].notna().all().all()
    pred = pd.read_csv(work / "results/eval/real/seed1.csv", keep_default_na=False)
    tiles = read_tiles(work / "results/tiles/real.zarr")
    assert len(pred) == int((tiles.labels.set == "test").sum()) > 0
    for name in ("fig12_boxplot.png", "confusion_real.png", "confusion_sub_cpi.csv"):
        assert (rep / name).stat().st_size > 0
    log = (work / "results/logs/train_classifier/real.log").read_text()  # a training set per job
    assert "epoch   1" in log and "kept the average of the weights of epochs" in log
    assert run(work, *CONFIG, "--report", "report.html", log=root / "report.log") == 0, (
        root / "report.log"
    ).read_text()[-3000:]
    assert (work / "report.html").stat().st_size > 0


#: modules an edit of which once reran no rule (the rerun probe edits each in a copy)
PROBED = (
    "synthesis/radar.py",
    "synthesis/processes.py",
    "spectra/floor.py",
    "io/flightzarr.py",
    "rotors/order.py",
    "rotors/fit.py",
)


def dry_run_rules(snakefile: Path, work: Path, log: Path) -> set[str]:
    """The rules a dry-run of ``snakefile`` in ``work`` would run for changed params."""
    with open(log, "w") as fh:
        rc = subprocess.run(
            [SNAKEMAKE, "-s", str(snakefile), "-d", str(work), *RUN, "-n", "--rerun-triggers", "params"],
            cwd=work,
            env=ENV,
            stdout=fh,
            stderr=subprocess.STDOUT,
            timeout=600,
        ).returncode
    text = log.read_text()
    assert rc == 0, text[-3000:]
    return set(re.findall(r"(?m)^rule (\w+):", text)) - {"default", "all"}


@pytest.mark.slow
def test_an_edit_of_any_imported_module_reruns_the_rules_that_import_it(reference, tmp_path):
    """After a complete run, a comment appended to a library module (in a copy of the
    workflow and its sources) makes a dry-run list every rule whose script imports it,
    and only those (and what follows from their outputs)."""
    from microdoppler.codeversion import import_closure

    root, _, text = reference
    work = root / "cluster"
    ran = set(re.findall(r"(?m)^rule (\w+):", text))  # the rules of this run (no batch merge)
    assert len(ran) >= 15, ran
    copy = tmp_path / "repo"
    copy.mkdir()
    for part in ("Snakefile", "workflow", "src", "profiles"):
        src = REPO / part
        (shutil.copytree if src.is_dir() else shutil.copy)(src, copy / part)
    assert dry_run_rules(copy / "Snakefile", work, tmp_path / "none.log") == set()
    pkg = copy / "src" / "microdoppler"
    for rel in PROBED:
        module = pkg / rel
        direct = {
            name
            for name, script in rule_scripts().items()
            if name in ran and module in import_closure(copy / "workflow" / "scripts" / script, package_dir=pkg)
        }
        assert direct, f"no rule imports {rel}"
        original = module.read_bytes()
        module.write_bytes(original + b"\n# an edit\n")
        try:
            rerun = dry_run_rules(copy / "Snakefile", work, tmp_path / f"{module.stem}.log")
        finally:
            module.write_bytes(original)
        assert direct <= rerun, f"{rel}: rules importing it but not rerun: {sorted(direct - rerun)}"


def rule_scripts() -> dict[str, str]:
    """rule name -> the file name of its script, from workflow/rules/*.smk."""
    out = {}
    for smk in sorted((REPO / "workflow" / "rules").glob("*.smk")):
        for m in re.finditer(r'(?ms)^\s*rule (\w+):.*?script:\s*\n\s*"\.\./scripts/([\w.]+)"', smk.read_text()):
            out[m.group(1)] = m.group(2)
    return out
