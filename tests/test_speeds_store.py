"""The compact speeds store (schema ``speeds/2``): knots and a recipe instead of
per-pulse speeds, rebuilding the ``speeds/1`` per-pulse float32 speeds, hence the
same twins.

The reference is a frozen copy of the ``speeds/1`` writer's per-pulse code (below),
not the library's current sampling, so a change of the recipe or the reader that
alters the twins fails here. Criterion: the rotor phase (integral of the speed, in
revolutions) within 1e-3 rev over a 200 s flight and the synthesised echo within
-60 dB relative energy; the rebuild is in fact bit-exact (both differences are 0).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from scipy.signal import decimate, resample_poly

from microdoppler.datasets import speeds
from microdoppler.datasets.stores import open_store, put_array, writing_store
from microdoppler.emulator.drone import DYNAMICS, loop_path, motor_speeds, write_log
from microdoppler.errors import InputError
from microdoppler.io.motorlog import MotorLog, read_ulog
from microdoppler.synthesis.radar import DRONE_MODELS
from microdoppler.synthesis.model import SynthesisConfig, Track, synthesize

PRF_HZ = 7300.0
N_FFT = 4096
SETTINGS = {"per_cpi": 8, "window_pulses_min": 1000, "window_pulses_max": 3500, "spread": 0.1}
PHASE_TOL_REV = 1e-3
IQ_TOL_DB = -60.0


# --- frozen speeds/1 per-pulse reference (microdoppler.rotors.sampling before speeds/2) ----


def _spline_at(log, m, t):
    spl = CubicSpline(log.time_s, log.rev_s[:, m], bc_type="natural", extrapolate=False)
    return spl(np.clip(t, log.time_s[0], log.time_s[-1]))


def _moving_average(x, w):
    if w <= 1:
        return x
    h = w // 2
    c = np.concatenate(
        [[0.0], np.cumsum(np.concatenate([np.full(h, x[0]), x, np.full(w - h, x[-1])]), dtype=np.float64)]
    )
    return (c[w : w + len(x)] - c[: len(x)]) / w


def speeds1_reference(base, log, n_pulses, window_pulses=None, fixed_rev_s=None, motors=None):
    """Per-pulse float32 [n_pulses, n_motors] rev/s as the speeds/1 store held them."""
    motors = list(range(log.n_motors)) if motors is None else motors
    out = np.empty((n_pulses, len(motors)), np.float32)
    if base == "fixed_speeds":
        out[...] = np.float32(fixed_rev_s)
        return out
    for j, m in enumerate(motors):
        if base == "per_cpi":
            n_cpi = -(-n_pulses // N_FFT)
            v = _spline_at(log, m, (np.arange(n_cpi) * N_FFT + N_FFT / 2) / PRF_HZ)
            out[:, j] = np.repeat(v, N_FFT)[:n_pulses]
            continue
        up, pad, over = N_FFT // SETTINGS["per_cpi"], 16, 8
        n_dec = -(-n_pulses // up) + 2 * pad
        fine = _spline_at(log, m, (np.arange(n_dec * over) - pad * over) / (PRF_HZ / up * over))
        x = resample_poly(decimate(fine, over, ftype="fir", zero_phase=True), up, 1)[pad * up : pad * up + n_pulses]
        out[:, j] = _moving_average(x, window_pulses)
    return out


# --- fixtures ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def flight200():
    """A 200 s Inspire 2 motor log as the emulator's drone writes it (30 Hz rows with
    jitter and drops, 1 rpm rounding) and its range track."""
    rng = np.random.default_rng(20261123)
    dyn = DYNAMICS["inspire2"]
    path = loop_path(200.0, mean_range_m=300.0, height_m=50.0, speed_mps=8.0, direction=1, hand_flown=False, rng=rng)
    t, rpm = write_log(motor_speeds(path, dyn, wind_mps=5.0, rng=rng), 200.0, dyn.log_rate_hz, rng)
    return MotorLog(t, rpm, "emulator inspire2 200 s"), Track(path.t_s, path.range_m)


def roundtrip(tmp_path, variant, log, n_pulses, seed=5):
    """Write one flight's compact speeds to a speeds/2 store and read them back."""
    sp, attrs = speeds.resample_flight_compact(
        variant, log, n_pulses, PRF_HZ, "inspire2", settings=SETTINGS, n_fft=N_FFT, seed=seed
    )
    store = tmp_path / f"{variant}.zarr"
    with writing_store(store, {"schema": speeds.SPEEDS_SCHEMA, "variant": variant}) as root:
        speeds.write_flight_speeds(root, "f1", sp, attrs)
    return speeds.read_rev_s(speeds.open_speeds(store)["f1"], f"{store}/f1"), attrs, store


def reference_of(variant, log, n_pulses, attrs):
    base = speeds.BASE_SAMPLING[variant]
    return speeds1_reference(
        "sub_cpi" if base == "single_motor" else base,
        log,
        n_pulses,
        attrs.get("window_pulses"),
        attrs.get("fixed_rev_s"),
        motors=[0] if base == "single_motor" else None,
    )


def store_bytes(path):
    return sum(f.stat().st_size for f in Path(path).rglob("*") if f.is_file())


# --- tests -------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("variant", list(speeds.BASE_SAMPLING))
def test_stored_speeds_give_the_speeds1_phase_over_200_s(tmp_path, flight200, variant):
    log, _ = flight200
    n = int(200.0 * PRF_HZ) + 77  # not a whole number of CPIs
    rev, attrs, store = roundtrip(tmp_path, variant, log, n)
    ref = reference_of(variant, log, n, attrs)
    assert rev.dtype == np.float32 and rev.shape == ref.shape == (n, 1 if variant == "single_motor" else 4)
    phase = np.cumsum(rev, axis=0, dtype=np.float64) / PRF_HZ
    phase_ref = np.cumsum(ref, axis=0, dtype=np.float64) / PRF_HZ
    assert np.abs(phase - phase_ref).max() < PHASE_TOL_REV
    assert np.array_equal(rev, ref)  # the recipe is the writer's own code: bit-exact
    # and far smaller than the per-pulse float32 speeds/1 array (>= 100x)
    assert store_bytes(store) * 100 < ref.nbytes, (store_bytes(store), ref.nbytes)
    if variant == "fixed_speeds":
        assert attrs["fixed_rev_s"] == pytest.approx(DRONE_MODELS["inspire2"].typical_motor_hz, rel=0.1)


@pytest.mark.parametrize("variant", ["sub_cpi", "per_cpi"])
def test_stored_speeds_give_the_speeds1_twin_echo(tmp_path, flight200, variant):
    """The synthesised echo of the 200 s flight (1.35 GHz, Inspire 2 blades) from the
    stored speeds is the speeds/1 one within -60 dB relative energy."""
    log, track = flight200
    n = int(200.0 * PRF_HZ)
    rev, attrs, _ = roundtrip(tmp_path, variant, log, n)
    ref = reference_of(variant, log, n, attrs)
    config = SynthesisConfig.of(prf_hz=PRF_HZ, wavelength_m=299792458.0 / 1.35e9, n_blades=2, blade_length_m=0.19)
    iq_ref = synthesize(config, track, ref, seed=11)

    def rel_db(iq):
        d = np.sum(np.abs(iq.astype(np.complex128) - iq_ref) ** 2) / np.sum(np.abs(iq_ref.astype(np.complex128)) ** 2)
        return 10 * np.log10(max(d, 1e-30))

    assert rel_db(synthesize(config, track, rev, seed=11)) < IQ_TOL_DB
    # the criterion has teeth: a speed bias of 1e-3 rev over the flight breaks it
    assert rel_db(synthesize(config, track, ref + np.float32(PHASE_TOL_REV / 200.0), seed=11)) > IQ_TOL_DB


@pytest.mark.parametrize("variant", ["sub_cpi", "per_cpi", "single_motor"])
def test_stored_speeds_of_a_real_px4_log(tmp_path, ulog_path, variant):
    log = read_ulog(ulog_path)
    n = int(log.duration_s * PRF_HZ)
    rev, attrs, _ = roundtrip(tmp_path, variant, log, n, seed=17)
    ref = reference_of(variant, log, n, attrs)
    phase_err = np.abs(np.cumsum(rev - ref.astype(np.float64), axis=0) / PRF_HZ).max()
    assert phase_err < PHASE_TOL_REV and np.array_equal(rev, ref)


def test_speeds1_store_is_refused(tmp_path):
    store = tmp_path / "old.zarr"
    with writing_store(store, {"schema": "speeds/1", "variant": "sub_cpi"}) as root:
        put_array(root.require_group("f1"), "rev_s", np.full((100, 4), 80.0, np.float32))
    with pytest.raises(InputError, match=r"old\.zarr: attrs\.schema: is 'speeds/1'.*re-run.*expected 'speeds/2'"):
        speeds.open_speeds(store)
    # a group holding the per-pulse array of speeds/1 names the missing knots
    with pytest.raises(InputError, match=r"f1: knots_rev_s: is missing \(a speeds/1 per-pulse array"):
        speeds.read_rev_s(open_store(store, "speeds/1")["f1"], f"{store}/f1")


def test_inconsistent_knots_are_refused(tmp_path, flight200):
    log, _ = flight200
    sp, attrs = speeds.resample_flight_compact(
        "sub_cpi", log, 50_000, PRF_HZ, "inspire2", settings=SETTINGS, n_fft=N_FFT, seed=1
    )
    bad = speeds.CompactSpeeds(sp.form, sp.knots_rev_s[:-1], sp.n_pulses, sp.params)
    store = tmp_path / "bad.zarr"
    with writing_store(store, {"schema": speeds.SPEEDS_SCHEMA}) as root:
        speeds.write_flight_speeds(root, "f1", bad, attrs)
        speeds.write_flight_speeds(root, "f2", sp, attrs)
        root["f2"].attrs["rev_s_form"] = "spline"
    g = speeds.open_speeds(store)
    with pytest.raises(InputError, match=r"f1: knots_rev_s: has \d+ knots for 50000 pulses.*expected \d+ knots"):
        speeds.read_rev_s(g["f1"], f"{store}/f1")
    with pytest.raises(InputError, match=r"f2: attrs.rev_s_form: is 'spline' \(expected 'hold' or 'sub_cpi'\)"):
        speeds.read_rev_s(g["f2"], f"{store}/f2")
