"""``microdoppler show``: one figure per store and a rotor-speed table whose numbers are
the store's own."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from conftest import make_flight, one_line, run_cli


def _estimate(flight_id="est1", n_cpi=6, n_motors=4, seed=3):
    """A radar estimate as :func:`~microdoppler.rotors.speed.estimate_rotor_speeds`
    returns it, with an ambiguous order (half the rate listed)."""
    from microdoppler.rotors.speed import RotorEstimate

    rng = np.random.default_rng(seed)
    t = 0.28 + 0.28 * np.arange(n_cpi)
    speeds = np.sort(80.0 + 3.0 * np.arange(n_motors) + rng.normal(0, 0.3, (n_cpi, n_motors)), axis=1)
    std = 0.2 + 0.1 * rng.random((n_cpi, n_motors))
    common = speeds.mean(axis=1)
    info = {
        "prf_hz": 7300.0,
        "method": "herm-pairs+iq-fit/2",
        "order": {
            "method": "order/7",
            "chosen_rev_s": round(float(common.mean()), 3),
            "lines_rev_s": 40.0,
            "ratio_to_lines": 2.0,
            "remeasured": "no",
            "ambiguous": True,
            "alternatives_rev_s": [round(float(common.mean()) / 2, 2)],
            "relative_likelihood": [0.8],
            "order_rel_std": 0.01,
        },
    }
    return RotorEstimate(
        flight_id,
        t,
        speeds,
        std,
        common,
        std.mean(axis=1),
        np.full(n_cpi, 3),
        np.full(n_cpi, n_motors),
        np.zeros(n_cpi),
        n_motors,
        2,
        4096,
        None,
        info,
    )


@pytest.fixture
def stores(tmp_path):
    from microdoppler.io.flightzarr import write_flight

    est = _estimate()
    radar = est.with_flight(make_flight("est1", n=4096 * 4, with_log=False))
    logged = make_flight("log1", n=4096 * 2)
    logged.motors_rpm = (logged.motors_rpm * np.linspace(0.9, 1.1, 4)[None, :]).astype(np.float32)
    bare = make_flight("bare1", n=4096 * 2, with_log=False)
    return {
        name: write_flight(tmp_path / f"{name}.zarr", f)
        for name, f in (("est1", radar), ("log1", logged), ("bare1", bare))
    }


def _read_table(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.slow
def test_show_writes_one_figure_per_store_and_the_table_holds_the_stores_numbers(tmp_path, stores, capsys):
    from microdoppler.cli import main
    from microdoppler.io.flightzarr import read_flight
    from microdoppler.views import TABLE_COLUMNS

    out = tmp_path / "look"
    rc = main([str(a) for a in ("show", *stores.values(), "--out", out)])
    printed = capsys.readouterr().out
    assert rc == 0
    for fid in stores:
        png = out / f"{fid}.png"
        assert png.is_file() and png.stat().st_size > 10_000
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    rows = _read_table(out / "rotor_speeds.csv")
    assert tuple(rows[0]) == TABLE_COLUMNS
    assert [r["flight_id"] for r in rows] == ["est1"] * 4 + ["log1"] * 4  # bare1 has no speeds

    g = read_flight(stores["est1"])
    rev = g.motors_rpm.astype(np.float64) / 60
    std = np.asarray(g.attrs["motors_radar"]["rpm_std"]) / 60
    order = g.attrs["motors_radar"]["rotor_order"]
    alt = g.attrs["motors_radar"]["rotor_order_alternatives_rev_s"]
    for j, r in enumerate(rows[:4]):
        assert int(r["rotor"]) == j + 1 and r["source"] == "radar"
        assert r["method"] == g.attrs["motors_radar"]["method"]
        assert float(r["mean_rev_s"]) == rev[:, j].mean()
        assert float(r["sigma_rev_s"]) == np.sqrt(np.mean(std[:, j] ** 2))
        assert float(r["mean_sigma_rev_s"]) == g.attrs["motors_radar"]["mean_rpm_std"][j] / 60
        assert float(r["scatter_rev_s"]) == np.std(rev[:, j], ddof=1)
        assert r["ambiguous"] == "yes" and order["ambiguous"]
        assert float(r["alternatives_rev_s"]) == rev[:, j].mean() * alt[0] / order["chosen_rev_s"]
        assert float(r["alternatives_likelihood"]) == g.attrs["motors_radar"]["rotor_order_relative_likelihood"][0]
        assert f"{rev[:, j].mean():.2f}" in printed
    h = read_flight(stores["log1"])
    for j, r in enumerate(rows[4:]):
        assert r["source"] == "log" and r["method"] == "motor log"
        assert float(r["mean_rev_s"]) == (h.motors_rpm[:, j].astype(np.float64) / 60).mean()
        assert (
            r["sigma_rev_s"] == ""
            and r["mean_sigma_rev_s"] == ""
            and r["ambiguous"] == ""
            and r["alternatives_rev_s"] == ""
        )
    assert "bare1.png: no rotor speeds" in printed and "--estimate-motors" in printed
    # the fields a recording cannot test: est1's speeds come from its own lines (its
    # blade count with them), log1's from a log (which tests the PRF and the blade count)
    untested = {tuple(x.split()[:2]) for x in printed.splitlines() if "not testable from this recording" in x}
    assert ("est1:", "n_blades") in untested, printed
    assert not {("log1:", "n_blades"), ("log1:", "prf_hz")} & untested, printed
    assert not any(u[0] == "bare1:" for u in untested)


def test_show_refuses_a_store_shorter_than_one_cpi_and_writes_nothing(tmp_path, capsys):
    from microdoppler.io.flightzarr import write_flight

    short = write_flight(tmp_path / "short.zarr", make_flight("short1", n=1000))
    out = tmp_path / "look"
    rc, err = run_cli(capsys, ["show", short, "--out", out])
    one_line(rc, err, "short1", "iq", "1000 pulses", "4096 pulses")


def test_show_never_replaces_files_it_did_not_write(tmp_path, stores, capsys):
    out = tmp_path / "look"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    rc, err = run_cli(capsys, ["show", stores["log1"], "--out", out, "--overwrite"])
    one_line(rc, err, "notes.txt")
    assert (out / "notes.txt").read_text() == "mine" and not (out / "log1.png").exists()


def test_the_docs_define_every_column_of_the_table():
    from pathlib import Path

    from microdoppler.views import COLUMN_DOC, TABLE_COLUMNS

    assert tuple(COLUMN_DOC) == TABLE_COLUMNS
    doc = (Path(__file__).resolve().parents[1] / "docs" / "recordings.md").read_text()
    for c in TABLE_COLUMNS:
        assert f"| `{c}` |" in doc, c
