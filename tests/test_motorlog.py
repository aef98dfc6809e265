"""Motor-log ingest: the real PX4 log and every kind of bad log."""

from __future__ import annotations

import numpy as np
import pytest

from microdoppler.cli import main
from microdoppler.errors import InputError
from microdoppler.io.motorlog import read_csv, read_motor_log, read_motor_store, read_ulog, write_motor_store


def test_real_ulog_ingests(ulog_path):
    log = read_ulog(ulog_path)
    assert log.n_motors == 4
    assert len(log.time_s) == 127
    assert log.duration_s == pytest.approx(38.9, abs=0.1)
    assert log.rpm.min() == pytest.approx(1334, abs=1)
    assert log.rpm.max() == pytest.approx(2976, abs=1)
    assert np.all(np.diff(log.time_s) > 0)


def test_real_ulog_roundtrip_store(ulog_path, tmp_path):
    log = read_ulog(ulog_path)
    write_motor_store(tmp_path / "m.zarr", log)
    back = read_motor_store(tmp_path / "m.zarr")
    np.testing.assert_array_equal(back.time_s, log.time_s)
    np.testing.assert_array_equal(back.rpm, log.rpm)


def _csv(path, t, rpm, cols=None):
    cols = cols or [f"m{i}" for i in range(rpm.shape[1])]
    with open(path, "w") as fh:
        fh.write(",".join(["time_s"] + cols) + "\n")
        for ti, row in zip(t, rpm):
            fh.write(",".join([repr(float(ti))] + [repr(float(v)) for v in row]) + "\n")
    return path


def _good(rng, n=50):
    t = np.arange(n) / 30.0
    rpm = 4800 + rng.normal(0, 50, (n, 4))
    return t, rpm


def test_good_csv_in_each_unit(tmp_path, rng):
    t, rpm = _good(rng)
    for unit, factor in (("rpm", 1.0), ("rev/s", 1 / 60), ("rad/s", 2 * np.pi / 60)):
        log = read_csv(_csv(tmp_path / "g.csv", t, rpm * factor), unit=unit)
        np.testing.assert_allclose(log.rpm, rpm, rtol=1e-5)


def _bad_logs(tmp_path, rng, ulog_bytes):
    t, rpm = _good(rng)
    cases = {}
    cases["empty"] = (tmp_path / "empty.csv", {}, "file")
    (tmp_path / "empty.csv").write_bytes(b"")
    nan = rpm.copy()
    nan[7, 2] = np.nan
    cases["nan"] = (_csv(tmp_path / "nan.csv", t, nan), {}, "m2")
    dup = t.copy()
    dup[10] = dup[9]
    cases["duplicate time"] = (_csv(tmp_path / "dup.csv", dup, rpm), {}, "time_s")
    dec = t.copy()
    dec[10] = dec[8]
    cases["decreasing time"] = (_csv(tmp_path / "dec.csv", dec, rpm), {}, "time_s")
    cases["missing motor column"] = (_csv(tmp_path / "miss.csv", t, rpm[:, :3]), {"n_motors": 4}, "motor columns")
    cases["rev/s declared as rpm"] = (_csv(tmp_path / "unit.csv", t, rpm / 60), {"unit": "rpm"}, "motor columns")
    cases["rpm declared as rev/s"] = (_csv(tmp_path / "unit2.csv", t, rpm), {"unit": "rev/s"}, "motor columns")
    if ulog_bytes is not None:
        (tmp_path / "trunc.ulg").write_bytes(ulog_bytes[: len(ulog_bytes) // 2 + 7])
        cases["truncated ulog"] = (tmp_path / "trunc.ulg", {}, "file")
        (tmp_path / "empty.ulg").write_bytes(b"")
        cases["empty ulog"] = (tmp_path / "empty.ulg", {}, "file")
    return cases


@pytest.fixture
def bad_logs(tmp_path, rng):
    from conftest import ULOG_FIXTURE

    data = ULOG_FIXTURE.read_bytes() if ULOG_FIXTURE.exists() else None
    return _bad_logs(tmp_path, rng, data)


def test_bad_logs_raise_input_error_naming_file_and_field(bad_logs):
    for name, (path, opts, field) in bad_logs.items():
        with pytest.raises(InputError) as exc:
            read_motor_log(path, **opts)
        msg = str(exc.value)
        assert "\n" not in msg, name
        assert str(path) in msg, (name, msg)
        assert field in exc.value.field, (name, exc.value.field)
        assert "expected" in msg, (name, msg)


def test_cli_ingest_bad_logs_exit_nonzero_one_line_nothing_written(bad_logs, tmp_path, capsys):
    for name, (path, opts, field) in bad_logs.items():
        out = tmp_path / f"out_{path.stem}.zarr"
        argv = ["ingest", str(path), "--out", str(out)]
        if "unit" in opts:
            argv += ["--unit", opts["unit"]]
        if "n_motors" in opts:
            argv += ["--n-motors", str(opts["n_motors"])]
        rc = main(argv)
        err = capsys.readouterr().err.strip()
        assert rc != 0, name
        assert len(err.splitlines()) == 1 and "Traceback" not in err, (name, err)
        assert str(path) in err and field in err, (name, err)
        assert not out.exists(), name
        assert not list(tmp_path.glob(f".out_{path.stem}.zarr.tmp-*")), name


def test_cli_ingest_real_log(ulog_path, tmp_path, capsys):
    out = tmp_path / "m.zarr"
    assert main(["ingest", str(ulog_path), "--out", str(out)]) == 0
    log = read_motor_store(out)
    assert log.n_motors == 4 and len(log.time_s) == 127
