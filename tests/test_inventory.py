"""Flight inventory and motor-log ingest over a directory of flight-zarr/1 stores."""

import numpy as np
import pandas as pd
import pytest

from microdoppler.errors import InputError
from microdoppler.io.flightzarr import Flight, write_flight
from microdoppler.io.inventory import ingest_flight_logs, list_flights, read_ingested_log


def _flight(fid, target="drone", with_log=True, rng=None):
    rng = rng or np.random.default_rng(0)
    n = 4096
    attrs = dict(
        schema="flight-zarr/1", flight_id=fid, target=target, radar_id="radar1", prf_hz=7300.0, carrier_hz=1.35e9
    )
    f = Flight(
        attrs=attrs,
        iq=(rng.standard_normal(n) + 0j).astype(np.complex64),
        track_time_s=np.array([0.0, 1.0]),
        track_range_m=np.array([1000.0, 1005.0]),
        track_radial_velocity_mps=np.array([5.0, 5.0]),
    )
    if target == "drone":
        attrs.update(drone_model="inspire2", n_motors=4, n_blades=2, blade_length_m=0.19)
        if with_log:
            f.motors_time_s = np.arange(20) / 30.0
            f.motors_rpm = np.full((20, 4), 4800.0, np.float32)
    return f


def test_ingest_uses_store_then_table_and_skips_flights_without_log(tmp_path):
    d = tmp_path / "measured"
    write_flight(d / "a.zarr", _flight("a"))
    write_flight(d / "b.zarr", _flight("b", with_log=False))
    write_flight(d / "c.zarr", _flight("c", with_log=False))
    write_flight(d / "bird1.zarr", _flight("bird1", target="bird"))
    csv = tmp_path / "c_log.csv"
    pd.DataFrame({"time_s": np.arange(10) / 20, **{f"m{i}": np.full(10, 60.0) for i in range(4)}}).to_csv(
        csv, index=False
    )
    table = tmp_path / "logs.tsv"
    pd.DataFrame(
        [{"flight_id": "c", "motor_log": "c_log.csv", "format": "csv", "unit": "rev/s", "time_offset_s": 0.5}]
    ).to_csv(table, sep="\t", index=False)

    flights = list_flights(d)
    assert set(flights.flight_id) == {"a", "b", "c", "bird1"}
    status = ingest_flight_logs(
        d, tmp_path / "logs.zarr", tmp_path / "ingest.csv", table_path=table, log=lambda *_: None
    )
    st = status.set_index("flight_id").status.to_dict()
    assert st == {"a": "ingested", "b": "skipped", "c": "ingested"}
    c = read_ingested_log(tmp_path / "logs.zarr", "c")
    np.testing.assert_allclose(c.rpm, 3600.0)  # 60 rev/s declared -> 3600 rpm
    np.testing.assert_allclose(c.time_s[0], 0.5)  # time offset applied
    assert read_ingested_log(tmp_path / "logs.zarr", "b") is None


def test_bad_store_in_directory_is_named(tmp_path):
    d = tmp_path / "measured"
    write_flight(d / "a.zarr", _flight("a"))
    import zarr

    g = zarr.open_group(str(d / "a.zarr"), mode="r+")
    g.attrs["schema"] = "flight-zarr/0"
    with pytest.raises(InputError, match=r"a\.zarr: attrs\.schema"):
        list_flights(d)


def test_empty_directory_is_an_error(tmp_path):
    (tmp_path / "m").mkdir()
    with pytest.raises(InputError, match="no \\*.zarr stores"):
        list_flights(tmp_path / "m")


@pytest.mark.slow
def test_ingest_estimates_missing_logs_from_the_radar(tmp_path):
    """An estimator: a drone without a log gets the radar's rotor speeds (status
    estimated, motors_source radar, a log the diagnosis recognises); a Mini (no
    visible sideband) stays skipped with the reason."""
    from microdoppler.emulator import FlightSpec, emulate_flight
    from microdoppler.io.inventory import RADAR_SOURCE
    from microdoppler.rotors.speed import estimate_rotor_speeds

    d = tmp_path / "measured"
    drone, _ = emulate_flight(
        FlightSpec("d1", "drone", drone_model="inspire2", duration_s=12.0, snr_db=44.0, mean_range_m=1000.0, seed=101)
    )
    true_rpm = float(np.median(drone.motors_rpm))
    drone.motors_time_s = drone.motors_rpm = None
    mini, _ = emulate_flight(FlightSpec("m1", "drone", drone_model="mini2", duration_s=8.0, seed=5))
    write_flight(d / "d1.zarr", drone)
    write_flight(d / "m1.zarr", mini)
    status = ingest_flight_logs(
        d, tmp_path / "logs.zarr", tmp_path / "ingest.csv", estimator=estimate_rotor_speeds, log=lambda *_: None
    ).set_index("flight_id")
    assert status.loc["d1", "status"] == "estimated" and status.loc["d1", "source"] == "radar"
    assert status.loc["m1", "status"] == "skipped" and "no estimate from the radar" in status.loc["m1", "reason"]
    log = read_ingested_log(tmp_path / "logs.zarr", "d1")
    assert log.source.startswith(RADAR_SOURCE)
    assert np.median(log.rpm) == pytest.approx(true_rpm, rel=0.02)
    plain = ingest_flight_logs(d, tmp_path / "logs2.zarr", tmp_path / "ingest2.csv", log=lambda *_: None)
    assert set(plain.status) == {"skipped"}
