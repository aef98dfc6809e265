"""The one-row-per-flight table that ``diagnose`` writes beside ``report.json``, the
hint of a skipped flight and the repetition of an import's plausibility warning."""

from __future__ import annotations

import csv
import json
from dataclasses import replace

import pytest

from conftest import one_line, run_cli
from microdoppler.diagnosis.pipeline import TABLE_COLUMNS
from microdoppler.emulator.world import FlightSpec, emulate_flight
from microdoppler.io.flightzarr import write_flight


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    d = tmp_path_factory.mktemp("diag_table")
    spec = FlightSpec(
        "tab01",
        "drone",
        drone_model="inspire2",
        duration_s=12.0,
        snr_db=40.0,
        effects={"sideband_asymmetry": {"asymmetry_db": 5.0}},
        seed=20261121,
    )
    flight, _ = emulate_flight(spec)
    nolog = replace(
        flight,
        attrs={**flight.attrs, "flight_id": "nolog1", "plausibility_warnings": ["prf_hz: a stored warning"]},
        motors_time_s=None,
        motors_rpm=None,
    )
    return [write_flight(d / f"{f.flight_id}.zarr", f) for f in (flight, nolog)]


@pytest.mark.slow
def test_diagnose_writes_a_table_whose_rows_are_the_reports_flights(tmp_path, stores, capsys):
    from microdoppler.cli import main

    out = tmp_path / "report.json"
    rc = main(["diagnose", *map(str, stores), "--out", str(out)])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    rep = json.loads(out.read_text())
    assert out.read_text() == json.dumps(rep, indent=1)  # the report as before: no table in it
    with open(tmp_path / "report.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0]) == TABLE_COLUMNS
    assert [r["flight_id"] for r in rows] == [e["flight_id"] for e in rep["flights"]] == ["tab01", "nolog1"]
    e, r = rep["flights"][0], rows[0]
    assert r["cause"] == e["cause"] == "sideband_asymmetry"
    assert r["causes"].split(";") == [c["cause"] for c in e["causes"]]
    assert json.loads(r["params"]) == {c["cause"]: (c.get("extension") or c)["params"] for c in e["causes"]}
    assert r["log_evalues"].split(";")[0] == f"sideband_asymmetry={e['causes'][0]['evidence']['log_evalue']}"
    assert r["not_testable"] == ";".join(f"{k}: {v}" for k, v in e["not_testable"].items())
    gof = e["evidence"]["goodness_of_fit"]
    assert r["goodness_of_fit"] == ("excess" if gof["excess"] else "explained")
    assert r["reason"] == r["hint"] == r["plausibility_warnings"] == ""
    s = rows[1]
    assert s["cause"] == "skipped" and s["reason"] == rep["flights"][1]["reason"] == "no motor log"
    assert "microdoppler import --estimate-motors" in s["hint"]
    assert s["params"] == s["goodness_of_fit"] == ""
    assert s["plausibility_warnings"] == "prf_hz: a stored warning"
    # the terminal: the hint with the skip, the stored warning repeated
    assert (
        "nolog1: skipped: no motor log (hint: import the recording with `microdoppler import --estimate-motors`"
        in cap.err
    )
    assert "nolog1: warning: imported despite an implausible set-up: prf_hz: a stored warning" in cap.err

    # a second run replaces the tool's own table only with --overwrite
    rc, err = run_cli(capsys, ["diagnose", stores[1], "--out", out])
    one_line(rc, err, "report", "already exists")
    rc, err = run_cli(capsys, ["diagnose", stores[1], "--out", out, "--overwrite"])
    assert rc == 0, err
    with open(tmp_path / "report.csv", newline="") as fh:
        assert [r["flight_id"] for r in csv.DictReader(fh)] == ["nolog1"]


def test_diagnose_never_replaces_a_csv_it_did_not_write(tmp_path, stores, capsys):
    (tmp_path / "report.csv").write_text("my,own\n1,2\n")
    rc, err = run_cli(capsys, ["diagnose", stores[1], "--out", tmp_path / "report.json", "--overwrite"])
    one_line(rc, err, "report.csv", "not a table this tool wrote")
    assert (tmp_path / "report.csv").read_text() == "my,own\n1,2\n"
    assert not (tmp_path / "report.json").exists()


def test_validate_repeats_the_stored_plausibility_warning(stores, capsys):
    from microdoppler.cli import main

    rc = main(["validate", "--quick", str(stores[1])])
    cap = capsys.readouterr()
    assert rc == 0 and cap.out.startswith("ok ")
    assert "imported with --force despite an implausible set-up: prf_hz: a stored warning" in cap.err


def test_a_store_whose_estimate_found_no_rotor_lines_points_at_its_set_up(tmp_path, stores, capsys):
    """A store whose import tried --estimate-motors and found no lines: the skip's hint
    says so and names the fields its plausibility warning doubts, not the
    --estimate-motors it already ran."""
    from microdoppler.cli import main
    from microdoppler.io.flightzarr import read_flight

    f = read_flight(stores[1])
    failed = replace(f, attrs={**f.attrs, "flight_id": "noest1", "motors_estimate_failed": "no sideband pair"})
    store = write_flight(tmp_path / "noest1.zarr", failed)
    out = tmp_path / "report.json"
    rc = main(["diagnose", str(store), "--out", str(out)])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    with open(tmp_path / "report.csv", newline="") as fh:
        row = next(csv.DictReader(fh))
    assert row["reason"] == "no motor log"
    assert row["hint"].startswith("the import's rotor-speed estimate found none (no sideband pair)")
    assert "check the declared prf_hz and import again" in row["hint"]
    assert "--estimate-motors" not in row["hint"]
    assert f"noest1: skipped: no motor log (hint: {row['hint']})" in cap.err


def _no_timings(obj):
    if isinstance(obj, dict):
        return {k: _no_timings(v) for k, v in obj.items() if k != "seconds"}
    if isinstance(obj, list):
        return [_no_timings(v) for v in obj]
    return obj


@pytest.mark.slow
def test_parts_gathered_give_the_report_of_one_job(tmp_path, stores):
    """The pipeline's diagnosis jobs (every n-th flight each) gathered by
    merge_reports: the same report, table and figures as one job over all flights;
    a flight in two parts is refused."""
    import pandas as pd

    from microdoppler.diagnosis.pipeline import diagnose_split, merge_reports
    from microdoppler.errors import InputError

    measured = stores[0].parent
    split = tmp_path / "flights.csv"
    ids = [p.name.removesuffix(".zarr") for p in stores]
    pd.DataFrame({"flight_id": ids, "set": "train", "target": "drone", "drone_model": "inspire2"}).to_csv(
        split, index=False
    )
    quiet = dict(log=lambda m: None)
    whole = diagnose_split(
        measured, tmp_path / "none.zarr", split, tmp_path / "all.json", tmp_path / "all_fig", **quiet
    )
    parts = [tmp_path / f"{i}.json" for i in range(2)]
    for i, p in enumerate(parts):
        diagnose_split(measured, tmp_path / "none.zarr", split, p, tmp_path / f"{i}_fig", part=(i, 2), **quiet)
    assert [len(json.loads(p.read_text())["flights"]) for p in parts] == [1, 1]
    merged = merge_reports(
        parts[::-1], split, tmp_path / "merged.json", [tmp_path / "0_fig", tmp_path / "1_fig"], tmp_path / "merged_fig"
    )
    assert _no_timings(merged) == _no_timings(whole)
    assert (tmp_path / "merged.csv").read_text() == (tmp_path / "all.csv").read_text()
    assert sorted(f.name for f in (tmp_path / "merged_fig").iterdir()) == sorted(
        f.name for f in (tmp_path / "all_fig").iterdir()
    )
    with pytest.raises(InputError, match="in two parts"):
        merge_reports([parts[0], parts[0]], split, tmp_path / "twice.json")
