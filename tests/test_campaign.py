"""A campaign of one's own: every stage runs on flights from any radar, or says why
not in one line (docs/campaign.md).

- the diagnosis's CPI and minimum duration follow seconds: a 20-s recording at a
  2 kHz PRF is long enough, a shorter one is skipped with the minimum in seconds;
- a campaign without birds: the classifier refuses one class in one line;
- a fidelity table that cannot be formed names the flights and the reason.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from any_radar import draw_case, make_recording
from microdoppler.classifier import TrainConfig, train
from microdoppler.classifier.data import toy_tiles
from microdoppler.diagnosis import DiagnosisConfig
from microdoppler.diagnosis.measure import Undiagnosable, check_diagnosable
from microdoppler.errors import InputError
from microdoppler.io.flightzarr import write_flight
from microdoppler.io.inventory import RADAR_SOURCE, missing_class_note
from microdoppler.io.motorlog import MotorLog

REPO = Path(__file__).resolve().parents[1]
SNAKEMAKE = shutil.which("snakemake") or str(Path(sys.executable).with_name("snakemake"))


def _recording(duration_s: float, prf_hz: float = 2000.0):
    """A flying drone of tests/any_radar.py at ``prf_hz`` (3.3 GHz, 0.15 m blades) and
    its true rotor speeds as a motor log."""
    case = draw_case(
        5,
        duration_s=duration_s,
        prf_hz=prf_hz,
        carrier_hz=3.3e9,
        blade_length_m=0.15,
        setup="flying",
        radial_speed_mps=4.0,
    )
    flight, truth = make_recording(case)
    log = MotorLog(np.asarray(truth["time_s"], float), (np.asarray(truth["rev_s"]) * 60.0).astype(np.float32), "truth")
    return flight, log


def test_diagnosis_cpi_follows_seconds():
    cfg = DiagnosisConfig()
    assert cfg.cpi_pulses(7300.0) == 4096  # the paper's radar: today's CPI
    assert cfg.cpi_pulses(2000.0) == 1024
    assert DiagnosisConfig(n_fft=4096).cpi_pulses(2000.0) == 4096


def test_twenty_second_flight_at_2khz_is_not_too_short():
    flight, log = _recording(20.0)
    assert len(flight.iq) == 40000
    check_diagnosable(flight, log, DiagnosisConfig())  # no Undiagnosable
    # the same flight with the CPI fixed at 4096 pulses (2 s) was skipped
    with pytest.raises(Undiagnosable) as exc:
        check_diagnosable(flight, log, DiagnosisConfig(n_fft=4096))
    assert exc.value.reason.startswith("flight too short: iq: has 40000 pulses at 2000 Hz = 20 s")


@pytest.mark.parametrize(
    "duration_s, min_duration_s, expect",
    [
        (4.0, 0.0, "expected >= 5.38 s: 20 CPIs of 0.512 s"),
        (8.0, 10.0, "expected >= 10 s: 20 CPIs of 0.512 s"),
    ],
)
def test_too_short_flight_says_the_minimum_in_seconds(duration_s, min_duration_s, expect):
    flight, log = _recording(duration_s)
    with pytest.raises(Undiagnosable) as exc:
        check_diagnosable(flight, log, DiagnosisConfig(min_duration_s=min_duration_s))
    reason = exc.value.reason
    assert "\n" not in reason
    assert reason.startswith(f"flight too short: iq: has {len(flight.iq)} pulses at 2000 Hz = {duration_s:g} s")
    assert expect in reason, reason
    assert exc.value.field == "iq"


def test_short_blades_are_diagnosed_where_the_radar_measured_their_lines():
    """0.08 m blades at 1.3 GHz are 0.35 wavelengths: too short by the prior rule, yet
    the rotor estimator measured their lines; a log estimated from the recording itself
    overrides the rule (the visibility rule agrees with the rotor estimator)."""
    case = draw_case(
        5, duration_s=12.0, prf_hz=2000.0, carrier_hz=1.3e9, blade_length_m=0.08, setup="flying", radial_speed_mps=4.0
    )
    flight, truth = make_recording(case)
    t, rpm = np.asarray(truth["time_s"], float), (np.asarray(truth["rev_s"]) * 60.0).astype(np.float32)
    with pytest.raises(Undiagnosable) as exc:
        check_diagnosable(flight, MotorLog(t, rpm, "a logger"), DiagnosisConfig())
    assert "rotor lines invisible" in exc.value.reason and "0.35 wavelengths" in exc.value.reason
    log = check_diagnosable(flight, MotorLog(t, rpm, f"{RADAR_SOURCE}measured/{flight.flight_id}"), DiagnosisConfig())
    assert log.n_motors == rpm.shape[1]


def test_an_implausible_speed_the_radar_estimated_points_at_the_set_up_not_a_unit():
    """Speeds the radar estimated have no declared unit: an implausible median points at
    the declared blade count, PRF and carrier; a logger's log still at its unit."""
    flight, log = _recording(12.0)
    fast = log.rpm * 100.0  # far beyond any drone rotor
    for source, expect, never in (
        ("a logger", "check the declared unit (rpm)", "n_blades"),
        (f"{RADAR_SOURCE}measured/{flight.flight_id}", "check the declared n_blades, prf_hz and carrier_hz", "unit"),
    ):
        with pytest.raises(Undiagnosable) as exc:
            check_diagnosable(flight, MotorLog(log.time_s, fast, source), DiagnosisConfig())
        reason = exc.value.reason
        assert "\n" not in reason and "implausible for a drone rotor" in reason
        assert expect in reason and never not in reason, reason


# ---------------------------------------------------------------- a campaign without birds


def _drone_campaign(folder, n: int = 2):
    """``n`` short drone recordings of tests/any_radar.py as flight-zarr stores."""
    folder.mkdir(parents=True, exist_ok=True)
    for k in range(n):
        flight, _ = make_recording(draw_case(20 + k, duration_s=0.5, prf_hz=2000.0))
        write_flight(folder / f"{flight.flight_id}.zarr", flight)
    return folder


def test_no_bird_flights_note(tmp_path):
    folder = _drone_campaign(tmp_path / "measured")
    assert missing_class_note(folder) == (
        f"classifier left out: the campaign in {folder} has no bird flights (2 drone flights); "
        "add bird recordings to train a bird/drone classifier"
    )
    both = {"a": "drone", "b": "bird", "c": "none", "d": "drone", "e": "bird", "f": "drone", "g": "bird"}
    assert missing_class_note(folder, both) == ""


def test_too_few_flights_for_a_split_note(tmp_path):
    """Both classes, but too few flights of one to give each set of the split one:
    the classifier is left out with one line naming the class and the minimum."""
    folder = _drone_campaign(tmp_path / "measured")
    targets = {"a": "drone", "b": "drone", "c": "drone", "d": "bird", "e": "bird"}
    assert missing_class_note(folder, targets) == (
        f"classifier left out: the campaign in {folder} has too few bird flights for a flight-disjoint "
        "train/test/validation split (2 bird flights, 3 drone flights; expected >= 3 of each class, one per set); "
        "add bird recordings"
    )
    note = missing_class_note(folder, {"a": "drone", "b": "bird"})
    assert "\n" not in note and "too few bird and drone flights" in note


def test_training_on_one_class_is_refused_in_one_line():
    tiles = toy_tiles(24, seed=3)
    drones = tiles.subset(tiles.labels["target"] == "drone")
    with pytest.raises(InputError) as exc:
        train(drones, drones, TrainConfig(max_epochs=1), seed=1)
    msg = str(exc.value)
    assert "\n" not in msg
    assert msg.startswith(f"training set: train.target: has drone tiles only ({len(drones)} tiles of ")
    assert msg.endswith(
        "(expected tiles of both classes, bird and drone: add bird recordings to train a bird/drone classifier)"
    )


def _snakemake_dry(work, *targets):
    return subprocess.run(
        [SNAKEMAKE, "-n", *targets, "-s", str(REPO / "Snakefile"), "-d", str(work), "--configfile", "config.yaml"],
        cwd=work,
        capture_output=True,
        text=True,
        timeout=600,
    )


@pytest.fixture(scope="module")
def drone_only_workdir(tmp_path_factory):
    work = tmp_path_factory.mktemp("campaign")
    _drone_campaign(work / "measured")
    cfg = yaml.safe_load((REPO / "config/config.yaml").read_text())
    cfg["measurements"].update(source="directory", directory="measured")
    cfg["figures"]["ulog"] = str((REPO / cfg["figures"]["ulog"]).resolve())
    (work / "config.yaml").write_text(yaml.safe_dump(cfg))
    return work


@pytest.mark.slow
def test_campaign_without_birds_leaves_the_classifier_out(drone_only_workdir):
    r = _snakemake_dry(drone_only_workdir)
    assert r.returncode == 0, r.stderr[-3000:]
    out = r.stdout + r.stderr
    note = (
        "classifier left out: the campaign in measured has no bird flights (2 drone flights); "
        "add bird recordings to train a bird/drone classifier"
    )
    assert out.count(note) == 1, out[-3000:]
    for rule in ("train_classifier", "evaluate_classifier", "report_metrics"):
        assert f"rule {rule}:" not in out and f"\n{rule} " not in out
    for rule in ("diagnose_flights", "report_fidelity", "synthesize_flights"):
        assert rule in out
    # the twins figure is drawn for the campaign's own drone model, not the emulated world's
    models = _campaign_models(drone_only_workdir / "measured")
    for m in models:
        assert f"results/figures/twins_{m}.png" in out
    assert "twins_inspire2.png" not in out and "twins_matrice300.png" not in out


def _campaign_models(measured):
    from microdoppler.io.inventory import drone_models

    models = drone_models(measured)
    assert models, "the campaign holds drone flights"
    return models


@pytest.mark.slow
def test_classifier_target_on_a_campaign_without_birds_fails_with_the_note(drone_only_workdir):
    r = _snakemake_dry(drone_only_workdir, "results/reports/table_v.csv")
    assert r.returncode != 0
    assert "classifier left out: the campaign in measured has no bird flights (2 drone flights)" in r.stderr


# ---------------------------------------------------------------- a fidelity table that cannot be formed


def _own_campaign(tmp_path):
    """Three drone flights of tests/any_radar.py (no background recording): c0 of a
    model of one's own with a motor log, c1 of the same model without, c2 a Mini 2
    with a log; their logs ingested. Returns (measured folder, logs store)."""
    from dataclasses import replace

    from microdoppler.io.inventory import ingest_flight_logs

    measured = tmp_path / "measured"
    measured.mkdir()
    for k, (model, with_log) in enumerate([("own_quad", True), ("own_quad", False), ("mini2", True)]):
        flight, truth = make_recording(draw_case(40 + k, duration_s=3.0, prf_hz=4000.0))
        rpm = (np.asarray(truth["rev_s"]) * 60.0).astype(np.float32)
        flight = replace(
            flight,
            attrs={**flight.attrs, "flight_id": f"c{k}", "drone_model": model},
            motors_time_s=np.asarray(truth["time_s"], float) if with_log else None,
            motors_rpm=rpm if with_log else None,
        )
        write_flight(measured / f"c{k}.zarr", flight)
    logs = tmp_path / "motors" / "logs.zarr"
    ingest_flight_logs(measured, logs, tmp_path / "motors" / "ingest.csv", log=lambda m: None)
    return measured, logs


def test_a_drone_model_of_ones_own_gets_twin_speeds(tmp_path):
    """Twins are made of a drone model the catalog does not hold (not of the Mini 2);
    fixed_speeds draws around its flights' median logged speed."""
    from microdoppler.datasets.speeds import build_speeds
    from microdoppler.datasets.stores import flight_ids, open_store
    from microdoppler.io.inventory import read_ingested_log

    measured, logs = _own_campaign(tmp_path)
    status = build_speeds(
        measured,
        logs,
        tmp_path / "fixed.zarr",
        variant="fixed_speeds",
        settings={"spread": 0.1},
        n_fft=4096,
        seed=7,
        log=lambda m: None,
    )
    assert list(status.flight_id) == ["c0", "c1"]
    assert status.set_index("flight_id").status.to_dict() == {"c0": "ok", "c1": "skipped"}
    root = open_store(tmp_path / "fixed.zarr", "speeds/2")
    assert flight_ids(root) == ["c0"]
    typical = float(np.median(read_ingested_log(logs, "c0").rev_s))
    assert abs(root["c0"].attrs["fixed_rev_s"] / typical - 1) <= 0.1


@pytest.mark.slow
def test_fidelity_table_not_formed_names_the_flights_and_why(tmp_path):
    """Drone flights without twins (no background recording; no motor log; a model no
    twin is made of): Table VI has no rows, the log and fidelity_left_out.csv name each
    flight with its reason in one line, and the figure is one panel saying why."""
    from microdoppler.datasets.fidelity import write_fidelity_report
    from microdoppler.datasets.imaging import spectrogram_for_flights
    from microdoppler.datasets.injection import INJECTED_SCHEMA
    from microdoppler.datasets.stores import writing_store

    measured, logs = _own_campaign(tmp_path)
    injected = {}
    for v in ("sub_cpi", "extended"):
        injected[v] = tmp_path / "injected" / f"{v}.zarr"
        with writing_store(injected[v], {"schema": INJECTED_SCHEMA, "variant": v}):
            pass
    lines = []
    out = tmp_path / "reports"
    table = write_fidelity_report(
        measured,
        logs,
        injected,
        out / "table_vi.csv",
        out / "fig_fidelity.png",
        out / "fidelity_flights.csv",
        spec_cfg=spectrogram_for_flights(None, measured, log=lambda m: None),
        left_out_csv=out / "fidelity_left_out.csv",
        n_boot=50,
        log=lines.append,
    )
    assert table.empty and pd.read_csv(out / "table_vi.csv").empty
    left = pd.read_csv(out / "fidelity_left_out.csv").set_index("flight_id")
    assert left.loc["c0", "reason"] == "no background recording (background/iq): no twin can be injected"
    assert left.loc["c1", "reason"] == "no motor log (neither in the store nor in the flights table)"
    assert left.loc["c2", "reason"].startswith(
        "no twins of drone model 'mini2': twins are made of inspire2, matrice300 and of drone models"
    )
    assert (left.variants == "sub_cpi extended").all()
    for fid in ("c0", "c1", "c2"):
        assert f"{fid}: left out of Table VI (sub_cpi extended): {left.loc[fid, 'reason']}" in lines
    assert lines[-1] == (
        "Table VI has no rows: no drone flight has a twin scored on held-out CPIs "
        "(3 drone flights left out, reasons above)"
    )
    assert (out / "fig_fidelity.png").stat().st_size > 0


# ---------------------------------------------------------------- the SNR of a drone on a stand


def _stand_and_flying(folder):
    """Two drone flights of tests/independent_generator.py at its 2.9 GHz / 9 kHz radar:
    ``stand`` (body at 0 Hz, in the clutter notch) and ``flying`` (8 m/s)."""
    from independent_generator import GenCase, make_flight

    folder.mkdir(parents=True, exist_ok=True)
    out = {}
    for fid, speed in (("stand", 0.0), ("flying", 8.0)):
        flight, _ = make_flight(GenCase(fid, seed=61, radar="gen_s", duration_s=6.0, speed_mps=speed))
        write_flight(folder / f"{fid}.zarr", flight)
        out[fid] = flight
    return out


def test_snr_of_a_drone_on_a_stand_is_read_on_its_rotor_lines(tmp_path):
    """A stand-mounted drone's body line is high-passed away: its SNR (the split's, Table
    III's, the images') is read on its rotor lines and says so; a flying drone's stays
    the body line's, and Table III without a rotor-line flight has no snr_line column."""
    from microdoppler.datasets.imaging import spectrogram_for_flights
    from microdoppler.datasets.tiles import tile_record
    from microdoppler.datasets.workflow import split_and_table_iii
    from microdoppler.spectra.snr import flight_body_snr_db, flight_line_snr_db

    flights = _stand_and_flying(tmp_path / "measured")
    spec_cfg = spectrogram_for_flights(None, tmp_path / "measured", log=lambda m: None)
    body_stand = flight_body_snr_db(flights["stand"], spec_cfg=spec_cfg)
    rotor_stand, line = flight_line_snr_db(flights["stand"], spec_cfg=spec_cfg)
    assert line == "rotor"
    # the generator's first sideband pair stands 8 dB below a 40 dB body: the rotor
    # lines are well above the noise, the notched body line is not
    assert np.median(rotor_stand) > 20.0 and np.median(body_stand) < 10.0
    flying, line = flight_line_snr_db(flights["flying"], spec_cfg=spec_cfg)
    assert line == "body" and np.array_equal(flying, flight_body_snr_db(flights["flying"], spec_cfg=spec_cfg))
    _, snr, line = tile_record(flights["stand"], flights["stand"].iq, spec_cfg)
    assert line == "rotor"

    lines = []
    split, table = split_and_table_iii(tmp_path / "measured", spec_cfg=spec_cfg, seed=1, log=lines.append)
    assert split.set_index("flight_id").snr_line.to_dict() == {"flying": "body", "stand": "rotor"}
    assert set(table.snr_line) <= {"body", "rotor", "body+rotor", ""}
    assert table[table["class"] == "all"].snr_line.tolist() == [
        "+".join(ln for ln in ("body", "rotor") if ln in set(split[split.set == s].snr_line))
        for s in ("train", "test", "validation")
    ]
    assert any(m.startswith("stand: ") and "rotor-line SNR (body in the clutter notch)" in m for m in lines)
    assert any(m.startswith("flying: ") and "body SNR" in m for m in lines)

    (tmp_path / "measured" / "stand.zarr").rename(tmp_path / "stand.zarr")
    split, table = split_and_table_iii(tmp_path / "measured", spec_cfg=spec_cfg, seed=1, log=lambda m: None)
    assert "snr_line" not in split.columns and "snr_line" not in table.columns


@pytest.mark.slow
def test_a_flight_without_visible_rotor_lines_is_named_in_the_fidelity_table(tmp_path):
    """A drone flight whose rotor lines stay below the visibility threshold: Table VI
    scores it on the body and floor features only, and fidelity_left_out.csv and the
    log name it with the reason in one line; a flight with visible lines is scored whole;
    a stand-mounted one on its rotor lines, named with why its body line is not."""
    from independent_generator import GenCase, make_flight

    from microdoppler.datasets.fidelity import ROTOR_LINE_DISTANCES, write_fidelity_report
    from microdoppler.datasets.imaging import spectrogram_for_flights
    from microdoppler.datasets.injection import INJECTED_SCHEMA
    from microdoppler.datasets.stores import put_array, writing_store
    from microdoppler.io.inventory import ingest_flight_logs

    measured = tmp_path / "measured"
    measured.mkdir()
    flights = {}
    # the generator's first sideband pair stands first_sideband_db below a 40 dB body
    for fid, below_db, speed_mps in (("lines", 8.0, 8.0), ("dark", 45.0, 8.0), ("stand", 8.0, 0.0)):
        flight, _ = make_flight(
            GenCase(fid, seed=71, radar="gen_s", duration_s=8.0, speed_mps=speed_mps, first_sideband_db=below_db)
        )
        write_flight(measured / f"{fid}.zarr", flight)
        flights[fid] = flight
    logs = tmp_path / "motors" / "logs.zarr"
    ingest_flight_logs(measured, logs, tmp_path / "motors" / "ingest.csv", log=lambda m: None)
    # each "twin" is its flight's own recording: scoring needs no synthesis here
    injected = {"sub_cpi": tmp_path / "injected" / "sub_cpi.zarr"}
    with writing_store(injected["sub_cpi"], {"schema": INJECTED_SCHEMA, "variant": "sub_cpi"}) as root:
        for fid, flight in flights.items():
            g = root.require_group(fid)
            g.attrs.update({"drone_model": flight.attrs["drone_model"], "calibration": {"holdout_block_cpis": 8}})
            put_array(g, "iq", flight.iq)
    lines = []
    out = tmp_path / "reports"
    table = write_fidelity_report(
        measured,
        logs,
        injected,
        out / "table_vi.csv",
        out / "fig_fidelity.png",
        out / "fidelity_flights.csv",
        spec_cfg=spectrogram_for_flights(None, measured, log=lambda m: None),
        left_out_csv=out / "fidelity_left_out.csv",
        n_boot=50,
        log=lines.append,
    )
    assert list(table.variant) == ["sub_cpi"] and table.n_flights.tolist() == [3]
    left = pd.read_csv(out / "fidelity_left_out.csv")
    assert sorted(left.flight_id) == ["dark", "stand"]
    reason = left.set_index("flight_id").reason["dark"]
    assert reason.startswith("rotor lines not visible on the held-out CPIs (first sideband pair below 10 dB in all ")
    assert "\n" not in reason and f"dark: left out of Table VI (sub_cpi): {reason}" in lines
    per = pd.read_csv(out / "fidelity_flights.csv").set_index("flight_id")
    assert "lines_visible" not in per.columns
    assert per.loc["dark", list(ROTOR_LINE_DISTANCES)].isna().all()
    assert np.isfinite(per.loc["dark", ["body_std_db", "floor_db"]].astype(float)).all()
    assert np.isfinite(per.loc["lines", ["line_hz", "n_pairs", "first_pair_db"]].astype(float)).all()
    # a stand-mounted drone: its body line is in the clutter notch, its rotor lines are scored
    stand = left.set_index("flight_id").reason["stand"]
    assert stand == (
        "body line in the clutter notch (hovering or stand-mounted): its body-line features "
        "(first_pair_db, body_std_db) are left out, the rotor lines scored about the track's body Doppler"
    )
    assert per.loc["stand", ["first_pair_db", "body_std_db"]].isna().all()
    assert np.isfinite(per.loc["stand", ["line_hz", "n_pairs", "nonmultiple_db"]].astype(float)).all()
