"""Model extensions as options of the synthesis stage (microdoppler.extensions)."""

import numpy as np
import pytest

from microdoppler.errors import InputError
from microdoppler.extensions import ExtensionSet, load_extensions, save_extensions
from microdoppler.motorlog import MotorLog
from microdoppler.synthesis import Scaling, Track, synthesize

PRF = 7300.0
LAM = 299792458.0 / 1.35e9


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)


def _blade_iq(ext, n=1 << 16, seed=3, rate=80.0):
    rev = np.full((n, 4), rate, np.float32) * np.array([1.0, 1.02, 0.985, 1.01], np.float32)
    kw = ext.synth_kwargs(prf_hz=PRF, n_pulses=n, seed=seed)
    kw.setdefault("envelope", _unit)  # same (FFT) envelope filter for both models
    track = Track.constant_velocity(1500.0, -5.0, n / PRF)
    return synthesize(rev, track, prf_hz=PRF, wavelength_m=LAM, n_blades=2, blade_length_m=0.19,
                      scaling=Scaling(0.0, 1.0, 0.003), seed=seed, **kw)


def _unit(f_hz):
    return np.ones(len(f_hz), np.float32)


def _sideband_ratio_db(iq):
    f_body = 2 * 5.0 / LAM
    X = np.fft.fftshift(np.abs(np.fft.fft(iq)) ** 2)
    f = np.fft.fftshift(np.fft.fftfreq(len(iq), 1 / PRF)) - f_body
    up = X[(f > 20) & (f < 1000)].sum()
    lo = X[(f < -20) & (f > -1000)].sum()
    return 10 * np.log10(up / lo)


@pytest.mark.parametrize("a_db", [-5.0, 3.0])
def test_asymmetry_sets_upper_over_lower_power(a_db):
    base = _sideband_ratio_db(_blade_iq(ExtensionSet()))
    ext = _sideband_ratio_db(_blade_iq(ExtensionSet({"sideband_asymmetry": {"asymmetry_db": a_db}})))
    assert abs(base) < 0.5  # the paper's model is symmetric
    assert ext - base == pytest.approx(a_db, abs=0.3)


def test_transform_log_lag_and_scale(rng):
    t = np.sort(rng.uniform(0, 10, 300))
    rpm = rng.uniform(4000, 5000, (300, 4)).astype(np.float32)
    log = MotorLog(t, rpm)
    out = ExtensionSet({"motor_log_lag": {"lag_s": 0.4}, "motor_speed_scale": {"scale": 1.07}}).transform_log(log)
    # a row stamped t reports the speed at t - lag: the corrected row time is t - lag
    np.testing.assert_allclose(out.time_s, t - 0.4)
    np.testing.assert_allclose(out.rpm, rpm * 1.07, rtol=1e-6)
    same = ExtensionSet().transform_log(log)
    np.testing.assert_array_equal(same.rpm, rpm)


@pytest.mark.parametrize("cause,param,hook", [("sideband_fading", "fading_std_db", "blade_hook"),
                                              ("body_fluctuation", "body_std_db", "body_hook")])
def test_gain_hooks_have_the_catalog_std(cause, param, hook):
    n = int(PRF * 400)
    p = {param: 4.0} if cause == "body_fluctuation" else {param: 4.0, "timescale_s": 1.0}
    kw = ExtensionSet({cause: p}).synth_kwargs(prf_hz=PRF, n_pulses=n, seed=5)
    t = np.arange(0, n, 100) / PRF
    x = np.ones(len(t), np.complex64)
    kw[hook](0, len(t), t, x)
    g_db = 20 * np.log10(np.abs(x))
    assert g_db.std() == pytest.approx(4.0, rel=0.15)
    assert abs(g_db.mean()) < 1.0


def test_phase_noise_is_band_limited_with_the_catalog_rms():
    n = 1 << 18
    iq = np.ones(n, np.complex64)
    out = ExtensionSet({"phase_noise": {"rms_rad": 0.05}}).post(iq, prf_hz=PRF, seed=9)
    th = np.angle(out)
    assert th.std() == pytest.approx(0.05, rel=0.05)
    S = np.abs(np.fft.fft(th)) ** 2
    f = np.abs(np.fft.fftfreq(n, 1 / PRF))
    assert S[f > 110].sum() < 1e-6 * S[f < 100].sum()


def test_same_seed_same_result_and_seed_matters():
    e = ExtensionSet({"sideband_fading": {"fading_std_db": 3.0, "timescale_s": 1.5},
                      "body_fluctuation": {"body_std_db": 3.0}, "phase_noise": {"rms_rad": 0.01}})
    a = e.post(_blade_iq(e, seed=1), prf_hz=PRF, seed=1)
    b = e.post(_blade_iq(e, seed=1), prf_hz=PRF, seed=1)
    c = e.post(_blade_iq(e, seed=2), prf_hz=PRF, seed=2)
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)


def test_save_load_roundtrip_and_bad_input(tmp_path):
    e = ExtensionSet({"sideband_asymmetry": {"asymmetry_db": 4.0}, "sideband_fading": {"fading_std_db": 3.5}},
                     {"base_variant": "sub_cpi"})
    p = save_extensions(e, tmp_path / "ext.yaml")
    back = load_extensions(p)
    assert back.effects == e.effects
    assert back.effects["sideband_fading"]["timescale_s"] == 1.5  # default filled in
    (tmp_path / "bad.yaml").write_text("schema: extensions/1\nextensions: {sideband_fading: {fading_db: 3}}\n")
    with pytest.raises(InputError, match="fading_db"):
        load_extensions(tmp_path / "bad.yaml")
    with pytest.raises(InputError, match="not a catalog cause"):
        ExtensionSet({"gremlins": {}})
    with pytest.raises(InputError, match="scale"):
        ExtensionSet({"motor_speed_scale": {"scale": -1}})
