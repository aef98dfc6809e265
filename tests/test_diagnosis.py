"""Hidden-effect tests of the diagnosis (issue 6).

Each hidden-effect test draws a catalog cause and a magnitude in the catalog's
detectable range from a seed the diagnosis never sees (os.urandom; printed, and
fixed with MICRODOPPLER_HIDDEN_SEED=<seed> to reproduce), emulates a 40 s measured
drone flight with the emulator (measured body SNR after the STFT >= 36 dB), runs the diagnosis
and checks the named cause and the fitted parameter (30 %; lag 0.1 s).
"""

import json
import os
import secrets

import numpy as np
import pytest

from microdoppler.catalog import CATALOG, CAUSES
from microdoppler.diagnosis import aggregate, diagnose, diagnose_flight
from microdoppler.emulator.world import FlightSpec, emulate_flight, measured_snr_db
from microdoppler.errors import InputError
from microdoppler.flightzarr import write_flight

N_HIDDEN = 4


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)


def _hidden_seed() -> int:
    env = os.environ.get("MICRODOPPLER_HIDDEN_SEED")
    return int(env) if env else secrets.randbits(32)


def draw_effect(rng: np.random.Generator, cause: str) -> dict:
    sign = float(rng.choice([-1.0, 1.0]))
    return {
        "sideband_asymmetry": lambda: {"asymmetry_db": sign * rng.uniform(3, 6)},
        "sideband_fading": lambda: {"fading_std_db": rng.uniform(3, 6), "timescale_s": rng.uniform(1, 2)},
        "body_fluctuation": lambda: {"body_std_db": rng.uniform(3, 6)},
        "motor_log_lag": lambda: {"lag_s": sign * rng.uniform(0.3, 1.0)},
        "motor_speed_scale": lambda: {"scale": 1 + sign * rng.uniform(0.05, 0.12)},
        "phase_noise": lambda: {"rms_rad": rng.uniform(0.006, 0.02)},
    }[cause]()


def _near_clutter_rise_db(flight) -> float:
    """Floor within 35-95 Hz of the clutter line: flight over background [dB]."""
    from microdoppler.diagnosis.features import stft_power

    a = stft_power(flight.iq, flight.prf_hz, 4096)
    b = stft_power(flight.background_iq, flight.prf_hz, 4096)
    sel = (np.abs(a.f_hz) > 35) & (np.abs(a.f_hz) < 95)
    return float(10 * np.log10(np.median(a.p[:, sel]) / np.median(b.p[:, sel])))


def emulate(cause, params, rng, seed):
    """A 40 s flight whose measured body SNR after the STFT is >= 36 dB (the issue's
    condition; a body that sits in the clutter notch for most of the flight is redrawn)."""
    for _ in range(6):
        spec = FlightSpec(f"hidden{seed % 1000}", "drone", drone_model=str(rng.choice(["inspire2", "matrice300"])),
                          radar_id=str(rng.choice(["radar1", "radar2"])), duration_s=40.0,
                          mean_range_m=float(rng.uniform(1000, 2500)), speed_mps=float(rng.uniform(3, 12)),
                          direction=int(rng.choice([1, -1])), snr_db=42.0,
                          effects={cause: params} if cause != "none" else {}, seed=int(rng.integers(2 ** 31)))
        flight, truth = emulate_flight(spec)
        if measured_snr_db(flight)[0] >= 36.0:
            break
    if cause == "phase_noise":
        # the catalog's detectable range: the floor near clutter raised by >= 6 dB
        for _ in range(4):
            rise = _near_clutter_rise_db(flight)
            if rise >= 6.0:
                break
            params = {"rms_rad": params["rms_rad"] * 10 ** ((8.0 - rise) / 20)}
            spec = FlightSpec(**{**spec.__dict__, "effects": {cause: params}})
            flight, truth = emulate_flight(spec)
    return flight, params, spec


def _check_param(cause, truth, fit):
    k = CAUSES[cause].main_param
    t, f = truth[k], fit[k]
    if cause == "motor_log_lag":
        assert abs(f - t) <= 0.1, (k, t, f)
    elif cause == "motor_speed_scale":
        assert abs((f - 1) - (t - 1)) <= 0.3 * abs(t - 1), (k, t, f)
    else:
        assert abs(f - t) <= 0.3 * abs(t), (k, t, f)


@pytest.mark.parametrize("draw", range(N_HIDDEN))
def test_hidden_effect_is_named_with_its_parameter(draw):
    seed = _hidden_seed()
    print(f"hidden seed {seed} (rerun: MICRODOPPLER_HIDDEN_SEED={seed})")
    hidden = np.random.default_rng(seed)
    causes = [c for c in CATALOG if c != "none"]
    cause = causes[int(hidden.integers(len(causes)))]
    params = draw_effect(hidden, cause)
    flight, params, spec = emulate(cause, params, hidden, seed)
    entry = diagnose_flight(flight, config={"figures": False})  # sees the flight only
    assert entry["cause"] == cause, f"hidden {cause} {params} ({spec.radar_id}, {spec.drone_model}), named " \
        f"{entry['cause']}: {json.dumps(entry['evidence']['tests'])[:1500]}"
    _check_param(cause, params, entry["extension"]["params"])
    assert entry["gain"]["held_out"] and entry["gain"]["extended"] < entry["gain"]["baseline"]


@pytest.mark.parametrize("radar_id", ["radar1", "radar2"])
def test_flight_without_effect_is_none(radar_id):
    seed = _hidden_seed()
    print(f"hidden seed {seed} (rerun: MICRODOPPLER_HIDDEN_SEED={seed})")
    hidden = np.random.default_rng(seed)
    spec = FlightSpec(f"clean{seed % 1000}", "drone", drone_model=str(hidden.choice(["inspire2", "matrice300"])),
                      radar_id=radar_id, duration_s=40.0, mean_range_m=float(hidden.uniform(1000, 2500)),
                      speed_mps=float(hidden.uniform(3, 12)), snr_db=42.0, seed=int(hidden.integers(2 ** 31)))
    flight, _ = emulate_flight(spec)
    entry = diagnose_flight(flight, config={"figures": False})
    assert entry["cause"] == "none", json.dumps(entry["evidence"]["tests"])[:1500]
    assert entry["extension"] is None


def test_report_file_follows_the_format_and_figure(tmp_path, rng):
    spec = FlightSpec("fmt01", "drone", drone_model="inspire2", duration_s=12.0, snr_db=40.0,
                      effects={"sideband_asymmetry": {"asymmetry_db": 5.0}}, seed=int(rng.integers(2 ** 31)))
    flight, _ = emulate_flight(spec)
    store = write_flight(tmp_path / "fmt01.zarr", flight)
    rep = diagnose([store], tmp_path / "report.json", figures_dir=tmp_path / "figs")
    on_disk = json.loads((tmp_path / "report.json").read_text())
    assert on_disk == json.loads(json.dumps(rep))
    assert on_disk["catalog"][0] == "none" and set(CATALOG) <= set(on_disk["catalog"])
    (e,) = on_disk["flights"]
    assert set(e) >= {"flight_id", "cause", "extension", "gain", "evidence"}
    assert e["cause"] in on_disk["catalog"]
    assert set(e["gain"]) >= {"metric", "baseline", "extended", "held_out"}
    if e["cause"] != "none":
        assert e["extension"]["name"] == e["cause"]
        assert set(e["extension"]["params"]) == {p.name for p in CAUSES[e["cause"]].params}
    assert (tmp_path / "figs" / "fmt01.png").stat().st_size > 10_000


def test_bird_and_missing_log_are_rejected(rng):
    bird, _ = emulate_flight(FlightSpec("b1", "bird", bird_kind="single", duration_s=4.0, seed=1))
    with pytest.raises(InputError, match="target"):
        diagnose_flight(bird)
    drone, _ = emulate_flight(FlightSpec("d1", "drone", drone_model="inspire2", duration_s=4.0, seed=2))
    drone.motors_time_s = drone.motors_rpm = None
    with pytest.raises(InputError, match="motor log"):
        diagnose_flight(drone)


def test_aggregate_keeps_frequent_causes_with_median_params():
    fl = [{"flight_id": f"f{i}", "cause": "sideband_asymmetry",
           "extension": {"name": "sideband_asymmetry", "params": {"asymmetry_db": a}}}
          for i, a in enumerate([3.0, 5.0, 4.0])]
    fl += [{"flight_id": "f9", "cause": "motor_log_lag", "extension": {"name": "motor_log_lag", "params": {"lag_s": 0.5}}},
           {"flight_id": "f8", "cause": "none", "extension": None}]
    ext = aggregate({"catalog": list(CATALOG), "flights": fl}, min_fraction=0.3)
    assert ext.effects == {"sideband_asymmetry": {"asymmetry_db": 4.0}}
    only = aggregate({"catalog": list(CATALOG), "flights": fl}, min_fraction=0.3, flight_ids={"f9", "f8"})
    assert set(only.effects) == {"motor_log_lag"}


def test_cli_rejects_a_bad_store_in_one_line(tmp_path, capsys):
    from microdoppler.cli import main

    (tmp_path / "bad.zarr").mkdir()
    rc = main(["diagnose", str(tmp_path / "bad.zarr"), "--out", str(tmp_path / "r.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "bad.zarr" in err[0]
    assert not (tmp_path / "r.json").exists()
