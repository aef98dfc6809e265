"""The ``extended`` variant's per-twin extensions (``extensions/2``).

Each twin carries its own flight's diagnosed causes (``per_flight``), or draws them
from the per-drone-model population (``population``); a twin of a flight with no
cause is its ``sub_cpi`` twin, byte for byte.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import yaml

from microdoppler.datasets import calibration, speeds
from microdoppler.datasets.extended import (
    SCHEMA,
    TwinExtensions,
    load_twin_extensions,
    save_twin_extensions,
    twin_extensions,
)
from microdoppler.datasets.injection import SYNTHETIC_SCHEMA
from microdoppler.datasets.stores import open_store
from microdoppler.diagnosis.aggregate import aggregate_twins
from microdoppler.diagnosis.pipeline import write_twin_extensions
from microdoppler.errors import InputError
from microdoppler.causes.extensions import ExtensionSet, save_extensions
from microdoppler.io.inventory import ingest_flight_logs
from microdoppler.spectra.spectrogram import SpectrogramConfig

from test_datasets_world import make_world


def _cause(name, **params):
    return {
        "cause": name,
        "extension": {"name": name, "params": params},
        "gain": {"metric": "m", "baseline": 1.0, "extended": 0.5, "held_out": True},
    }


def _report():
    """Inspire flights: asymmetry +4 dB (3 of 4), fading on one; Matrice: asymmetry
    -5 dB on both, a lag on one; one skipped, one with no cause."""
    fl = [
        {
            "flight_id": "i1",
            "cause": "sideband_asymmetry",
            "causes": [
                _cause("sideband_asymmetry", asymmetry_db=4.0),
                _cause("sideband_fading", fading_std_db=4.0, timescale_s=1.2),
            ],
        },
        {"flight_id": "i2", "cause": "sideband_asymmetry", "causes": [_cause("sideband_asymmetry", asymmetry_db=4.4)]},
        {"flight_id": "i3", "cause": "sideband_asymmetry", "causes": [_cause("sideband_asymmetry", asymmetry_db=3.6)]},
        {"flight_id": "i4", "cause": "none", "causes": []},
        {
            "flight_id": "m1",
            "cause": "sideband_asymmetry",
            "causes": [_cause("sideband_asymmetry", asymmetry_db=-5.0), _cause("motor_log_lag", lag_s=0.5)],
        },
        {"flight_id": "m2", "cause": "sideband_asymmetry", "causes": [_cause("sideband_asymmetry", asymmetry_db=-5.4)]},
        {"flight_id": "m3", "cause": "skipped", "causes": [], "reason": "no usable motor log"},
    ]
    return {"schema": "diagnosis-report/2", "catalog": [], "flights": fl}


MODELS = {
    "i1": "inspire2",
    "i2": "inspire2",
    "i3": "inspire2",
    "i4": "inspire2",
    "m1": "matrice300",
    "m2": "matrice300",
    "m3": "matrice300",
}


def test_per_flight_mapping():
    ext = aggregate_twins(_report(), MODELS)
    assert ext.mode == "per_flight"
    e = ext.for_flight("i1", "inspire2", seed=7)
    assert e.effects == {
        "sideband_asymmetry": {"asymmetry_db": 4.0},
        "sideband_fading": {"fading_std_db": 4.0, "timescale_s": 1.2},
    }
    assert e.meta["source"] == "own"
    assert ext.for_flight("m1", "matrice300", seed=7).effects == {
        "sideband_asymmetry": {"asymmetry_db": -5.0},
        "motor_log_lag": {"lag_s": 0.5},
    }
    none = ext.for_flight("i4", "inspire2", seed=7)
    assert none.effects == {} and none.meta["source"] == "own"
    skipped = ext.for_flight("m3", "matrice300", seed=7)
    assert skipped.effects == {} and skipped.meta["source"] == "skipped"
    # a flight the diagnosis never saw draws from its model's population
    other = ext.for_flight("x9", "matrice300", seed=7)
    assert other.meta["source"] == "population"
    # population: over diagnosed flights only (m3 skipped), incidence per model
    pop = ext.population
    assert pop["inspire2"]["n_flights"] == 4 and pop["matrice300"]["n_flights"] == 2
    assert pop["inspire2"]["causes"]["sideband_asymmetry"]["incidence"] == pytest.approx(0.75)
    assert pop["inspire2"]["causes"]["sideband_fading"]["incidence"] == pytest.approx(0.25)
    assert pop["matrice300"]["causes"]["sideband_asymmetry"]["incidence"] == pytest.approx(1.0)
    assert "motor_log_lag" not in pop["inspire2"]["causes"]
    # only the given flights
    sub = aggregate_twins(_report(), MODELS, flight_ids={"i1", "m2"})
    assert set(sub.flights) == {"i1", "m2"}


def test_population_draws_deterministic_and_per_model():
    ext = aggregate_twins(_report(), MODELS, mode="population")
    fids = [f"log{i:03d}" for i in range(400)]
    a = [ext.for_flight(f, "inspire2", seed=7).effects for f in fids]
    assert a == [ext.for_flight(f, "inspire2", seed=7).effects for f in fids]
    assert a != [ext.for_flight(f, "inspire2", seed=8).effects for f in fids]
    # "when chosen": a diagnosed flight draws too
    assert ext.for_flight("i4", "inspire2", seed=7).meta["source"] == "population"
    m = [ext.for_flight(f, "matrice300", seed=7).effects for f in fids]
    # per model, sign included: Inspire asymmetries from {4.0, 4.4, 3.6}, Matrice's from {-5.0, -5.4}
    ai = [e["sideband_asymmetry"]["asymmetry_db"] for e in a if "sideband_asymmetry" in e]
    am = [e["sideband_asymmetry"]["asymmetry_db"] for e in m if "sideband_asymmetry" in e]
    assert set(ai) == {4.0, 4.4, 3.6} and set(am) == {-5.0, -5.4}
    assert len(am) == len(fids)  # incidence 1
    # incidence: asymmetry 0.75 and fading 0.25 of the Inspire twins (binomial, 4 sigma)
    for cause, p in (("sideband_asymmetry", 0.75), ("sideband_fading", 0.25)):
        k = sum(cause in e for e in a)
        assert abs(k / len(fids) - p) < 4 * np.sqrt(p * (1 - p) / len(fids)), (cause, k)
    assert not any("motor_log_lag" in e for e in a)
    assert 0.3 < sum("motor_log_lag" in e for e in m) / len(fids) < 0.7
    # a fading draw keeps its flight's parameters together
    assert all(e["sideband_fading"] == {"fading_std_db": 4.0, "timescale_s": 1.2} for e in a if "sideband_fading" in e)
    # a model with no diagnosed flight: no extension
    assert ext.for_flight("z", "mini2", seed=7).effects == {}


def test_yaml_roundtrip_and_v1(tmp_path):
    ext = aggregate_twins(_report(), MODELS)
    path = save_twin_extensions(ext, tmp_path / "extended.yaml")
    assert yaml.safe_load(path.read_text())["schema"] == SCHEMA
    back = load_twin_extensions(path)
    assert isinstance(back, TwinExtensions) and back.flights == ext.flights and back.population == ext.population
    assert load_twin_extensions(path, mode="population").mode == "population"
    for fid, model in MODELS.items():
        assert back.for_flight(fid, model, seed=3).effects == ext.for_flight(fid, model, seed=3).effects
    v1 = save_extensions(ExtensionSet({"sideband_asymmetry": {"asymmetry_db": -5.0}}), tmp_path / "v1.yaml")
    one = load_twin_extensions(v1)
    assert isinstance(one, ExtensionSet)
    assert twin_extensions(one, "any", "inspire2", seed=1) is one
    assert twin_extensions(None, "any", "inspire2", seed=1) is None


def test_write_twin_extensions_from_report_and_split(tmp_path):
    report = tmp_path / "report.json"
    report.write_text(json.dumps(_report()))
    split = tmp_path / "flights.csv"
    rows = [
        dict(flight_id=f, set="train" if f != "i3" else "test", target="drone", drone_model=m, radar_id="r1")
        for f, m in MODELS.items()
    ]
    pd.DataFrame(rows).to_csv(split, index=False)
    ext = write_twin_extensions(
        report, split, tmp_path / "extended.yaml", settings={"sets": ["train"]}, mode="per_flight"
    )
    assert "i3" not in ext.flights and ext.flights["m1"]["drone_model"] == "matrice300"
    back = load_twin_extensions(tmp_path / "extended.yaml")
    assert back.mode == "per_flight" and back.flights == ext.flights
    # every set diagnosed (the default), population from train only: the test flight's
    # twin carries its own causes, but its causes are not in the population
    both = write_twin_extensions(report, split, tmp_path / "extended2.yaml", settings={}, mode="per_flight")
    assert both.flights["i3"] == aggregate_twins(_report(), MODELS).flights["i3"]
    assert both.meta["population_sets"] == ["train"] and both.meta["n_population_flights"] == 5
    assert both.population == ext.population
    everything = aggregate_twins(_report(), MODELS)
    assert everything.population != ext.population  # i3 would have changed it


@pytest.mark.parametrize(
    "mutate, field",
    [
        (lambda d: d.update(mode="median"), "mode"),
        (lambda d: d["flights"]["i1"].update(status="maybe"), "flights.i1.status"),
        (lambda d: d["flights"]["i1"]["extensions"].update(wobble={"x": 1}), "flights.i1.extensions.wobble"),
        (
            lambda d: d["flights"]["i1"]["extensions"]["sideband_asymmetry"].update(asymmetry_db="big"),
            "flights.i1.extensions.sideband_asymmetry.asymmetry_db",
        ),
        (
            lambda d: d["population"]["inspire2"]["causes"]["sideband_asymmetry"].update(incidence=1.5),
            "population.inspire2.causes.sideband_asymmetry.incidence",
        ),
        (
            lambda d: d["population"]["inspire2"]["causes"]["sideband_asymmetry"].update(samples=[]),
            "population.inspire2.causes.sideband_asymmetry.samples",
        ),
        (lambda d: d.update(flights=[1, 2]), "flights"),
        (lambda d: d.update(schema="extensions/9"), "schema"),
    ],
)
def test_bad_yaml_is_one_line_input_error(tmp_path, mutate, field):
    d = aggregate_twins(_report(), MODELS).to_dict()
    mutate(d)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(d))
    with pytest.raises(InputError) as exc:
        load_twin_extensions(path)
    msg = str(exc.value)
    assert "\n" not in msg and str(path) in msg and f": {field}:" in msg, msg


def test_unreadable_yaml_and_bad_report(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("schema: [unclosed")
    with pytest.raises(InputError, match="is not YAML"):
        load_twin_extensions(path)
    with pytest.raises(InputError, match="does not exist"):
        load_twin_extensions(tmp_path / "missing.yaml")
    with pytest.raises(InputError, match="flights"):
        aggregate_twins({"flights": "x"}, MODELS)
    with pytest.raises(InputError, match="mode"):
        aggregate_twins(_report(), MODELS, mode="median")


SETTINGS = {"per_cpi": 8, "window_pulses_min": 1500, "window_pulses_max": 3000}


@pytest.mark.slow
def test_twin_without_cause_equals_sub_cpi_twin(tmp_path):
    """Through the speeds and twin stages: ins1 (no cause) gives the sub_cpi twin's
    iq byte for byte; mat1 (its own asymmetry) differs from its sub_cpi twin and
    records its extensions."""
    measured = make_world(tmp_path / "measured", duration_s=8.0)
    logs = tmp_path / "logs.zarr"
    ingest_flight_logs(measured, logs, tmp_path / "ingest.csv", log=lambda m: None)
    ext = TwinExtensions(
        {
            "ins1": {"drone_model": "inspire2", "status": "diagnosed", "extensions": {}},
            "mat1": {
                "drone_model": "matrice300",
                "status": "diagnosed",
                "extensions": {"sideband_asymmetry": {"asymmetry_db": -6.0}},
            },
            "mat2": {"drone_model": "matrice300", "status": "skipped", "extensions": {}},
        }
    )
    cfg = calibration.CalibrationConfig(n_alpha=3, max_iter=3)
    iq = {}
    for variant, e in (("sub_cpi", None), ("extended", ext)):
        speeds.build_speeds(
            measured,
            logs,
            tmp_path / f"speeds_{variant}.zarr",
            variant=variant,
            settings=SETTINGS,
            n_fft=4096,
            seed=7,
            extensions=e,
            log=lambda m: None,
        )
        calibration.build_twins(
            measured,
            tmp_path / f"speeds_{variant}.zarr",
            logs,
            tmp_path / f"{variant}.zarr",
            tmp_path / f"t4_{variant}.csv",
            variant=variant,
            spec_cfg=SpectrogramConfig(),
            cfg=cfg,
            seed=7,
            extensions=e,
            log=lambda m: None,
        )
        root = open_store(tmp_path / f"{variant}.zarr", SYNTHETIC_SCHEMA)
        iq[variant] = {fid: (np.asarray(root[fid]["iq"][...]), dict(root[fid].attrs)) for fid in root.group_keys()}
    assert {"ins1", "mat1", "mat2"} <= set(iq["sub_cpi"]) and set(iq["sub_cpi"]) == set(iq["extended"])
    for fid in ("ins1", "mat2"):
        assert iq["extended"][fid][0].tobytes() == iq["sub_cpi"][fid][0].tobytes(), fid
    assert iq["extended"]["ins1"][1]["extensions"] == {"effects": {}, "source": "own"}
    assert iq["extended"]["mat2"][1]["extensions"]["source"] == "skipped"
    assert iq["extended"]["mat1"][0].tobytes() != iq["sub_cpi"]["mat1"][0].tobytes()
    assert iq["extended"]["mat1"][1]["extensions"] == {
        "effects": {"sideband_asymmetry": {"asymmetry_db": -6.0}},
        "source": "own",
    }
    # ins2 is not in the map: a population draw (the population is empty here: no extension)
    assert iq["extended"]["ins2"][1]["extensions"]["source"] == "population"


@pytest.mark.slow
def test_extended_twin_carries_the_flights_blade_imbalance(tmp_path):
    """An emulated flight whose airframe has a 7 dB weak blade: its ``extended`` twin
    (own cause blade_imbalance) shows the odd rotation-rate lines at the measured
    flight's level (Table VI's nonmultiple_db, held-out CPIs), its ``sub_cpi`` twin
    (eq. 1's identical blades) shows none; the twin records the extension."""
    from dataclasses import replace

    from microdoppler.datasets import fidelity
    from microdoppler.datasets.injection import inject
    from microdoppler.emulator import FlightSpec, emulate_world
    from microdoppler.io.flightzarr import read_flight
    from microdoppler.io.inventory import read_ingested_log

    x = 7.0
    spec = FlightSpec(
        flight_id="imb_inspire2",
        target="drone",
        drone_model="inspire2",
        radar_id="radar1",
        duration_s=24.0,
        mean_range_m=1200.0,
        height_m=80.0,
        speed_mps=6.0,
        seed=3,
        snr_db=50.0,
        wind_mps=2.0,
        path="straight",
        first_sideband_db=8.0,
        harmonic_falloff_db=5.0,
        effects={"blade_imbalance": {"imbalance_db": x}},
        airframe="inspire2-A",
    )
    measured = tmp_path / "measured"
    emulate_world("default", 1, measured, progress=False, workers=1, specs=[replace(spec)])
    logs = tmp_path / "logs.zarr"
    ingest_flight_logs(measured, logs, tmp_path / "ingest.csv", log=lambda m: None)
    ext = TwinExtensions(
        {
            spec.flight_id: {
                "drone_model": "inspire2",
                "status": "diagnosed",
                "extensions": {"blade_imbalance": {"imbalance_db": x}},
            }
        }
    )
    cfg = calibration.CalibrationConfig(n_alpha=3, max_iter=3)
    flight = read_flight(measured / f"{spec.flight_id}.zarr")
    ml = read_ingested_log(logs, spec.flight_id)
    spec_cfg = SpectrogramConfig()
    meas = fidelity.flight_features(flight, flight.iq, ml, spec_cfg=spec_cfg)
    got = {}
    for variant, e in (("sub_cpi", None), ("extended", ext)):
        speeds.build_speeds(
            measured,
            logs,
            tmp_path / f"speeds_{variant}.zarr",
            variant=variant,
            settings=SETTINGS,
            n_fft=4096,
            seed=7,
            extensions=e,
            log=lambda m: None,
        )
        calibration.build_twins(
            measured,
            tmp_path / f"speeds_{variant}.zarr",
            logs,
            tmp_path / f"{variant}.zarr",
            tmp_path / f"t4_{variant}.csv",
            variant=variant,
            spec_cfg=spec_cfg,
            cfg=cfg,
            seed=7,
            extensions=e,
            log=lambda m: None,
        )
        g = open_store(tmp_path / f"{variant}.zarr", SYNTHETIC_SCHEMA)[spec.flight_id]
        twin = fidelity.flight_features(
            flight, inject(np.asarray(g["iq"][...]), flight.background_iq), ml, spec_cfg=spec_cfg
        )
        mask, held_out = fidelity.scoring_mask(dict(g.attrs["calibration"]), len(twin.time_s))
        assert held_out
        got[variant] = (fidelity.nonmultiple_db(meas, mask), fidelity.nonmultiple_db(twin, mask), dict(g.attrs))
    m_db, ext_db, attrs = got["extended"]
    a = 10 ** (-x / 20)
    # the emulator's tapered blade vs the twin's thin wire: ~1 dB apart at order 3
    assert abs(m_db - 20 * np.log10((1 - a) / (1 + a))) < 1.5, m_db
    assert abs(ext_db - m_db) < 1.5, (ext_db, m_db)
    assert got["sub_cpi"][1] < -25.0
    assert attrs["extensions"] == {"effects": {"blade_imbalance": {"imbalance_db": x}}, "source": "own"}


def test_unexplained_and_imbalance_in_the_report():
    """``unexplained`` names no extension: the twins' map and the one-set aggregate
    leave it out; ``blade_imbalance`` is carried like every catalog cause (per flight
    and in the population draw)."""
    from microdoppler.diagnosis.aggregate import aggregate

    rep = _report()
    rep["flights"][1]["causes"] = rep["flights"][1]["causes"] + [
        _cause("blade_imbalance", imbalance_db=6.5),
        {"cause": "unexplained", "params": {"excess_db": 4.0, "band_hz": [100.0, 200.0]}},
    ]
    ext = aggregate_twins(rep, MODELS)
    assert ext.flights["i2"]["extensions"] == {
        "sideband_asymmetry": {"asymmetry_db": 4.4},
        "blade_imbalance": {"imbalance_db": 6.5},
    }
    assert ext.population["inspire2"]["causes"]["blade_imbalance"]["samples"] == [{"imbalance_db": 6.5}]
    one = ext.for_flight("i2", "inspire2", seed=0)
    amps = one.blade_amplitudes(2)
    assert abs(amps.sum() - 2) < 1e-12 and abs(20 * np.log10(amps[0] / amps[1]) + 6.5) < 1e-9
    assert "unexplained" not in aggregate(rep, min_fraction=0.0).effects
