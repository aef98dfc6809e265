"""Shared fixtures: a seeded rng, the real PX4 motor log, small flight stores; the
fast loop's parameter split (:func:`fast_loop`); how runs use the cores.

- The whole suite, ``python -m pytest -q`` (README command 2, CI), adds to the fast
  loop the tests marked ``slow``: whole-workflow runs, and the statistical tests whose
  evidence is many seeded flights.
- The fast loop, ``python -m pytest -q -m "not slow"``: every module of
  src/microdoppler imported and exercised, each test under about a second (a test
  that takes longer on a quiet 2-core machine is marked ``slow``; 731 tests in 97 s
  with other work on the cores, 2026-11-29).
- Both spread their tests over the machine's cores (pytest-xdist, ``-n auto`` in
  pyproject.toml); a run that names files or tests (``python -m pytest tests/test_x.py``)
  stays in one process (:func:`pytest_xdist_auto_num_workers`), and ``-n 0`` keeps any
  run in one. ``--dist loadscope``: a module's tests run on one worker, so a module-scoped
  fixture (a workflow run, a built world) is built once; the longest modules start
  first (:data:`LONGEST_FIRST`, ``--no-loadscope-reorder``), so that none of them is
  left to run alone at the end.
- One BLAS/OpenMP thread per process (set here, before NumPy loads, unless the caller
  set it): the workers already use every core, and the I/Q fit's small products ran
  3.7x slower on two threads than on one (README command 2 without
  ``OMP_NUM_THREADS=1`` did not finish in 12 min). Subprocesses (workflow runs) inherit it."""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
#: the real PX4 log, referenced relative to the repository root
ULOG_FIXTURE = REPO / ".." / "shared" / "data" / "motor-logs" / "px4_esc_status.ulg"


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_auto_num_workers(config):
    """``-n auto`` (pyproject's addopts): the cores for the configured test paths (the
    whole suite, the fast loop); one process, no workers, for named files or tests."""
    if config.args_source != pytest.Config.ArgsSource.TESTPATHS:
        return 0
    return None  # xdist's own count of the cores


#: the modules that take longest, longest first (CPU seconds per module on 2 cores,
#: 2026-11-26: 140 with its cluster jobs, 98, 76, 74, 59, 53, 32, 31, 25), handed to
#: the workers first; the others follow in their collection order
LONGEST_FIRST = (
    "test_workflow_runs",
    "test_rotorspeed",
    "test_rotorfit_uncertainty",
    "test_diagnosis",
    "test_diagnosis_independent",
    "test_datasets_workflow",
    "test_rotorfit",
    "test_rotor_order",
    "test_fading_fine",
)


def pytest_collection_modifyitems(config, items):
    """The modules of :data:`LONGEST_FIRST` first, in that order (a stable sort: the
    tests of a module keep theirs)."""
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(getattr(getattr(item, "module", None), "__name__", ""), len(rank)))


@pytest.fixture
def rng():
    return np.random.default_rng(20260521)


@pytest.fixture
def ulog_path():
    """The real PX4 log. Missing is a failure, not a skip: the tests that use it (ULog
    parsing, corruption handling, motor-model calibration) must never vanish silently."""
    if not ULOG_FIXTURE.is_file():
        pytest.fail(
            f"real motor log not found: expected {ULOG_FIXTURE.resolve()} "
            f"(../shared/data/motor-logs/px4_esc_status.ulg next to the repository {REPO})",
            pytrace=False,
        )
    return ULOG_FIXTURE


def fast_loop(values, fast):
    """``values`` for ``pytest.mark.parametrize``: those for which ``fast(value)`` is true
    run in the fast loop, the others are marked ``slow`` (the whole suite runs them all)."""
    out = []
    for v in values:
        args = v if isinstance(v, tuple) else (v,)
        out.append(pytest.param(*args) if fast(v) else pytest.param(*args, marks=pytest.mark.slow))
    return out


def make_flight(fid="f1", n=4096, rng=None, with_log=True):
    """A small valid drone flight (flight-zarr/1) in memory."""
    from microdoppler.io.flightzarr import Flight

    rng = rng if rng is not None else np.random.default_rng(0)
    attrs = dict(
        schema="flight-zarr/1",
        flight_id=fid,
        target="drone",
        radar_id="radar1",
        prf_hz=7300.0,
        carrier_hz=1.35e9,
        drone_model="inspire2",
        n_motors=4,
        n_blades=2,
        blade_length_m=0.19,
    )
    iq = (rng.standard_normal(n) + 1j * rng.standard_normal(n)).astype(np.complex64)
    f = Flight(
        attrs=attrs,
        iq=iq,
        track_time_s=np.array([0.0, 0.5, 1.0]),
        track_range_m=np.array([1000.0, 1002.5, 1005.0]),
        track_radial_velocity_mps=np.array([5.0, 5.0, 5.0]),
    )
    if with_log:
        f.motors_time_s = np.arange(20) / 30.0
        f.motors_rpm = np.full((20, 4), 4800.0, np.float32)
    return f


@pytest.fixture
def good_store(tmp_path, rng):
    from microdoppler.io.flightzarr import write_flight

    return write_flight(tmp_path / "good.zarr", make_flight(rng=rng))


def run_cli(capsys, argv):
    """``microdoppler ARGV`` in-process: (exit status, stderr stripped)."""
    from microdoppler.cli import main

    rc = main([str(a) for a in argv])
    return rc, capsys.readouterr().err.strip()


def one_line(rc, err, *must):
    """A bad-input failure: exit status 2, one line, no traceback, naming ``must``."""
    assert rc == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for m in must:
        assert m in err, (m, err)
