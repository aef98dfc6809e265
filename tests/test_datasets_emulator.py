"""Twins of the measurement emulator's 'test' world (richer physics than the paper's
model: motor dynamics, clutter, phase noise, sideband asymmetry on one flight)."""

from __future__ import annotations

import pytest

from microdoppler import emulator
from microdoppler.datasets import calibration, speeds
from microdoppler.datasets.split import TWIN_MODELS
from microdoppler.io.inventory import ingest_flight_logs
from microdoppler.spectra.spectrogram import SpectrogramConfig


@pytest.mark.slow
def test_emulated_twins_match_their_flights(tmp_path):
    specs = [s for s in emulator.plan_world("test", 5) if s.drone_model in TWIN_MODELS]
    assert specs
    measured = tmp_path / "measured"
    emulator.emulate_world("test", 5, measured, specs=specs, progress=False, workers=1)
    ingest_flight_logs(
        measured,
        tmp_path / "logs.zarr",
        tmp_path / "ingest.csv",
        table_path=measured / "motor_logs.tsv",
        log=lambda m: None,
    )
    settings = {"per_cpi": 8, "window_pulses_min": 1500, "window_pulses_max": 3000}
    speeds.build_speeds(
        measured,
        tmp_path / "logs.zarr",
        tmp_path / "speeds.zarr",
        variant="sub_cpi",
        settings=settings,
        n_fft=4096,
        seed=7,
        log=lambda m: None,
    )
    t4 = calibration.build_twins(
        measured,
        tmp_path / "speeds.zarr",
        tmp_path / "logs.zarr",
        tmp_path / "twins.zarr",
        tmp_path / "table_iv.csv",
        variant="sub_cpi",
        spec_cfg=SpectrogramConfig(),
        cfg=calibration.CalibrationConfig(),
        seed=7,
        log=lambda m: None,
    )
    assert len(t4) == len(specs)
    assert (t4.status == "ok").all(), t4.to_string()
    assert (t4.body_error_db.abs() <= 2).all() and (t4.sideband1_error_db.abs() <= 2).all()
    # measured large drones show sidebands, and the twins show as many pairs within one
    assert (t4.n_pairs_measured >= 1).all()
    assert ((t4.n_pairs_twin - t4.n_pairs_measured).abs() <= 1).all()
