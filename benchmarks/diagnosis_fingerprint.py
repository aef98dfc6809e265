"""Fingerprint of the diagnosis on a few seeded emulated flights (no pipeline run).

Emulates one 40 s flight per catalog cause (and a clean one, and two with two causes
at once) with the measurement emulator, seeded; diagnoses each flight; builds the
twins' extensions (``extensions/2``, per flight and per population) from the report;
applies every cause's twin extension to fixed arrays. Prints a sha256 of

- ``world``: the emulated flights (echo, background, motor log) and their truth,
- ``report``: the report entries with the timings removed,
- ``extended``: the ``extended.yaml`` bytes of both modes,
- ``twins``: what every cause's extension does to a fixed echo, log and blade set,

and one of all four. Two versions of the code that print the same hashes diagnose,
extend and emulate these flights alike, bit for bit.

Usage: ``PYTHONPATH=src python benchmarks/diagnosis_fingerprint.py [--figure DIR]``
(``--figure`` also draws each flight's diagnosis figure into DIR; the figures are not
hashed). Takes a few minutes on one core.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import tempfile
from pathlib import Path

import numpy as np

from microdoppler.diagnosis.aggregate import aggregate_twins
from microdoppler.diagnosis.pipeline import diagnose_flight
from microdoppler.datasets.extended import save_twin_extensions
from microdoppler.emulator.world import FlightSpec, emulate_flight
from microdoppler.io.motorlog import MotorLog

try:  # where the twins' extensions live
    from microdoppler.causes.extensions import ExtensionSet
except ImportError:
    from microdoppler.causes.extensions import ExtensionSet

#: (flight id, drone model, radar, effects, seed); the effects in the catalog's detectable range
FLIGHTS = [
    ("clean", "inspire2", "radar1", {}, 11),
    ("asym", "matrice300", "radar2", {"sideband_asymmetry": {"asymmetry_db": 4.5}}, 12),
    ("fading", "inspire2", "radar1", {"sideband_fading": {"fading_std_db": 4.5, "timescale_s": 1.5}}, 13),
    ("body", "matrice300", "radar1", {"body_fluctuation": {"body_std_db": 4.5}}, 14),
    ("lag", "inspire2", "radar2", {"motor_log_lag": {"lag_s": 0.6}}, 15),
    ("scale", "matrice300", "radar1", {"motor_speed_scale": {"scale": 1.08}}, 16),
    ("pn", "inspire2", "radar1", {"phase_noise": {"rms_rad": 0.015}}, 17),
    ("imb", "matrice300", "radar1", {"blade_imbalance": {"imbalance_db": 8.0}}, 18),
    ("lagscale", "inspire2", "radar1", {"motor_log_lag": {"lag_s": -0.5}, "motor_speed_scale": {"scale": 0.93}}, 19),
    (
        "pnasym",
        "matrice300",
        "radar1",
        {"phase_noise": {"rms_rad": 0.012}, "sideband_asymmetry": {"asymmetry_db": -4.0}},
        20,
    ),
]
#: one of every cause's extension, for the twins' hash
ALL_EFFECTS = {
    "sideband_asymmetry": {"asymmetry_db": 3.5},
    "sideband_fading": {"fading_std_db": 4.0, "timescale_s": 1.2},
    "body_fluctuation": {"body_std_db": 3.0, "timescale_s": 0.4},
    "motor_log_lag": {"lag_s": 0.4},
    "motor_speed_scale": {"scale": 1.06},
    "phase_noise": {"rms_rad": 0.01},
    "blade_imbalance": {"imbalance_db": 6.0},
}


def _update(h, x):
    if isinstance(x, np.ndarray):
        h.update(str((x.dtype, x.shape)).encode())
        h.update(np.ascontiguousarray(x).tobytes())
    else:
        h.update(json.dumps(x, sort_keys=True, default=str).encode())


def _strip_timings(x):
    if isinstance(x, dict):
        return {k: _strip_timings(v) for k, v in x.items() if k != "seconds"}
    if isinstance(x, list):
        return [_strip_timings(v) for v in x]
    return x


def twins_hash() -> str:
    """Every cause's extension applied to fixed arrays."""
    h = hashlib.sha256()
    for cause, params in ALL_EFFECTS.items():
        for effects in ({cause: params}, ALL_EFFECTS):
            ext = ExtensionSet(effects)
            _update(h, ext.to_dict())
            log = MotorLog(np.linspace(0.0, 10.0, 101), np.full((101, 4), 6000.0, np.float32), "fixed")
            t = ext.transform_log(log)
            _update(h, t.time_s)
            _update(h, t.rpm)
            me = ext.model_extensions(prf_hz=20_000.0, n_pulses=40_000, seed=5)
            ts = np.linspace(0.0, 2.0, 4000)
            if me.envelope_gain is not None:
                _update(h, me.envelope_gain(np.linspace(-5000.0, 5000.0, 101)))
            for hook in (me.blade_hook, me.body_hook):
                if hook is not None:
                    x = np.ones(len(ts), np.complex64)
                    hook(0, len(ts), ts, x)
                    _update(h, x)
            a = ext.blade_amplitudes(2)
            if a is not None:
                _update(h, a)
            iq = np.exp(1j * np.linspace(0.0, 300.0, 8000)).astype(np.complex64)
            _update(h, ext.post(iq, prf_hz=20_000.0, seed=7))
    return h.hexdigest()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--figure", type=Path, default=None, help="also draw each flight's figure into this folder")
    args = ap.parse_args(argv)
    hw, hr = hashlib.sha256(), hashlib.sha256()
    entries, models = [], {}
    for fid, model, radar, effects, seed in FLIGHTS:
        spec = FlightSpec(
            fid,
            "drone",
            drone_model=model,
            radar_id=radar,
            duration_s=40.0,
            mean_range_m=1500.0,
            speed_mps=8.0,
            snr_db=48.0,
            effects=effects,
            seed=seed,
        )
        flight, truth = emulate_flight(spec)
        for x in (flight.iq, flight.background_iq, flight.motors_time_s, flight.motors_rpm):
            _update(hw, np.asarray(x))
        _update(hw, truth)
        fig = None
        if args.figure is not None:
            args.figure.mkdir(parents=True, exist_ok=True)
            fig = args.figure / f"{fid}.png"
        entry = diagnose_flight(flight, config={"figures": fig is not None}, figure_path=fig)
        entry = _strip_timings(entry)
        _update(hr, entry)
        entries.append(entry)
        models[fid] = model
        print(f"{fid}: {[c['cause'] for c in entry['causes']]}", flush=True)
    report = {"schema": "diagnosis-report/2", "flights": entries}
    he = hashlib.sha256()
    with tempfile.TemporaryDirectory() as tmp:
        for mode in ("per_flight", "population"):
            ext = aggregate_twins(report, models, mode=mode)
            p = Path(tmp) / f"extended_{mode}.yaml"
            save_twin_extensions(ext, p)
            he.update(p.read_bytes())
    out = {"world": hw.hexdigest(), "report": hr.hexdigest(), "extended": he.hexdigest(), "twins": twins_hash()}
    for k, v in out.items():
        print(f"{k:9s} {v}")
    print(f"{'all':9s} {hashlib.sha256(json.dumps(out, sort_keys=True).encode()).hexdigest()}")


if __name__ == "__main__":
    main()
