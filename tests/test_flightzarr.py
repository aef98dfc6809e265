"""flight-zarr/1 validator: a good store passes, each broken contract is named."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import zarr

from conftest import make_flight
from microdoppler.cli import main
from microdoppler.errors import InputError
from microdoppler.io.flightzarr import read_flight, validate_store, write_flight


def test_good_store_passes_and_roundtrips(good_store):
    f = validate_store(good_store)
    assert f.attrs["schema"] == "flight-zarr/1"
    full = read_flight(good_store)
    assert full.iq.dtype == np.complex64 and full.motors_rpm.shape == (20, 4)


def _break(store, how):
    g = zarr.open_group(str(store), mode="r+")
    if how == "missing array":
        del g["track/range_m"]
        return "track/range_m"
    if how == "wrong dtype":
        a = np.asarray(g["track/time_s"][...]).astype(np.float32)
        del g["track/time_s"]
        g.create_array("track/time_s", data=a)
        return "track/time_s"
    if how == "non-increasing times":
        t = np.asarray(g["track/time_s"][...])
        t[1] = t[0]
        g["track/time_s"][...] = t
        return "track/time_s"
    if how == "non-increasing motor times":
        t = np.asarray(g["motors/time_s"][...])
        t[5] = t[3]
        g["motors/time_s"][...] = t
        return "motors/time_s"
    if how == "wrong schema":
        g.attrs["schema"] = "flight-zarr/0"
        return "attrs.schema"
    raise AssertionError(how)


HOWS = ["missing array", "wrong dtype", "non-increasing times", "non-increasing motor times", "wrong schema"]


@pytest.mark.parametrize("how", HOWS)
def test_broken_store_rejected_with_one_line(good_store, tmp_path, how):
    store = tmp_path / "bad.zarr"
    shutil.copytree(good_store, store)
    field = _break(store, how)
    with pytest.raises(InputError) as exc:
        validate_store(store)
    msg = str(exc.value)
    assert "\n" not in msg and str(store) in msg and exc.value.field == field, msg


def test_cli_validate_reports_each_bad_store(good_store, tmp_path, capsys):
    bad = []
    for how in HOWS:
        s = tmp_path / f"bad_{how.replace(' ', '_')}.zarr"
        shutil.copytree(good_store, s)
        _break(s, how)
        bad.append(s)
    rc = main(["validate", str(good_store), *map(str, bad)])
    cap = capsys.readouterr()
    assert rc == 2
    lines = cap.err.strip().splitlines()
    assert len(lines) == len(bad) and "Traceback" not in cap.err
    for s, line in zip(bad, lines):
        assert str(s) in line
    assert cap.out.startswith(f"ok {good_store}")
    assert main(["validate", str(good_store)]) == 0


def test_write_is_atomic_and_refuses_bad_flight(tmp_path, rng):
    f = make_flight(rng=rng)
    f.track_time_s = np.array([0.0, 0.0, 1.0])
    with pytest.raises(InputError):
        write_flight(tmp_path / "x.zarr", f)
    assert not any(tmp_path.iterdir())
