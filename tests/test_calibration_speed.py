"""The capped, linear-STFT calibration (datasets.calibration): its spectrogram and line
measures equal the project's, its search never reads the held-out fold, and capping
the search leaves the fit where the full search puts it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from microdoppler.datasets import calibration
from microdoppler.datasets.lines import body_doppler_hz, measure_lines, rotor_rate_at
from microdoppler.diagnosis.hypotheses import folds
from microdoppler.emulator import FlightSpec, emulate_flight
from microdoppler.io.motorlog import MotorLog
from microdoppler.rotors.sampling import resample
from microdoppler.spectra.spectrogram import SpectrogramConfig, highpass, spectrogram
from microdoppler.synthesis.model import ModelExtensions

SPEC = SpectrogramConfig()
FAST = dict(n_alpha=4, max_iter=4)


@pytest.fixture(scope="module")
def drone():
    """A 40 s emulated Inspire flight (141 CPIs, 72 in fold A), its log and sub_cpi rates."""
    fl, _ = emulate_flight(FlightSpec("cal1", "drone", drone_model="inspire2", duration_s=40.0, seed=21, snr_db=42.0))
    log = MotorLog(np.asarray(fl.motors_time_s, float), np.asarray(fl.motors_rpm, np.float32), "test")
    return fl, log, resample("sub_cpi", log, len(fl.iq), fl.prf_hz)


def test_stft_and_line_windows_equal_the_spectrogram_and_measure_lines(drone):
    fl, _, rev = drone
    ref = spectrogram(fl.iq, fl.prf_hz, SPEC)
    st = calibration.StftColumns(len(fl.iq), fl.prf_hz, SPEC)
    got = st.spectrogram(fl.iq)
    assert np.array_equal(got.time_s, ref.time_s) and np.array_equal(got.doppler_hz, ref.doppler_hz)
    seg = fl.background_iq[5000:19336]
    assert np.array_equal(st.highpass(seg), highpass(seg, fl.prf_hz, SPEC.highpass_hz, SPEC.highpass_order))
    assert np.abs(np.median(got.power_db, 1) - np.median(ref.power_db, 1)).max() < 1e-3
    assert np.abs(got.power_db.max(1) - ref.power_db.max(1)).max() < 1e-3
    # columns of a sum = sum of columns (the fit combines components linearly)
    cpis = np.array([3, 4, 40, 77])
    a, b = st.columns(st.highpass(fl.iq), cpis), st.columns(st.highpass(fl.background_iq), cpis)
    ab = st.columns(st.highpass(fl.iq + fl.background_iq), cpis)
    assert np.abs(ab - (a + b)).max() <= 1e-4 * np.abs(ab).max()
    rate, spread = rotor_rate_at(rev, ref.time_s, fl.prf_hz)
    body = body_doppler_hz(fl.track_time_s, fl.track_radial_velocity_mps, fl.wavelength_m, ref.time_s)
    kw = dict(n_blades=2, rotor_half_spread_rev_s=float(np.percentile(spread, 90)), n_harmonics=6, search_hz=10.0)
    want = measure_lines(ref, body, rate, **kw)
    have, floor = calibration.LineWindows(ref.doppler_hz, body, rate, **kw).measure(ref.power_db)
    for k in ("body_db", "upper_db", "lower_db"):
        assert np.array_equal(getattr(want, k), getattr(have, k)), k
    assert np.array_equal(floor, np.median(ref.power_db, axis=1))


def test_search_cpis_are_a_spread_subset_of_fold_a():
    cfg = calibration.CalibrationConfig(max_fit_cpis=16)
    mask = cfg.fit_mask(141)
    sel = cfg.search_cpis(mask)
    assert len(sel) == 16 and mask[sel].all() and np.all(np.diff(sel) > 0)
    assert sel[0] == 0 and sel[-1] >= 128  # runs spread from the first to the last block
    assert np.array_equal(sel, cfg.search_cpis(mask))
    assert np.array_equal(replace(cfg, max_fit_cpis=0).search_cpis(mask), np.flatnonzero(mask))
    assert np.array_equal(replace(cfg, max_fit_cpis=500).search_cpis(mask), np.flatnonzero(mask))
    with pytest.raises(ValueError, match="max_fit_cpis"):
        calibration.CalibrationConfig(max_fit_cpis=-1)


def _garble_fold_b(fl, block: int, seed: int):
    """The flight with its pulses that no fold-A CPI window comes within 4096 pulses of
    replaced by strong noise (measured and background)."""
    st = calibration.StftColumns(len(fl.iq), fl.prf_hz, SPEC)
    near = np.zeros(len(fl.iq), bool)
    for s in st.frame_start[folds(st.n_timesteps, block) == 0]:
        near[max(0, s - 4096) : s + SPEC.n_fft + 4096] = True
    far = ~near
    assert far.sum() > 20000
    rng = np.random.default_rng(seed)
    out = replace(fl, iq=fl.iq.copy(), background_iq=fl.background_iq.copy())
    for x in (out.iq, out.background_iq):
        x[far] = (rng.standard_normal(far.sum()) + 1j * rng.standard_normal(far.sum())).astype(np.complex64) * 1e3
    return out


@pytest.mark.slow
def test_capped_fit_never_reads_fold_b(drone):
    """Garbling the measured flight and background far inside fold B leaves the fit as
    it is; without a hold-out the same garbling changes it (the check can fail)."""
    fl, log, rev = drone
    bad = _garble_fold_b(fl, 8, seed=4)
    res = {}
    for block in (8, 0):
        cfg = calibration.CalibrationConfig(holdout_block_cpis=block, max_fit_cpis=16, **FAST)
        for name, f in (("clean", fl), ("garbled", bad)):
            res[block, name] = calibration.fit_twin(f, rev, log, spec_cfg=SPEC, cfg=cfg, seed=5)[1]
    a, b = res[8, "clean"], res[8, "garbled"]
    assert a["n_search_cpis"] == 16 and a["n_fit_cpis"] == 72
    assert a["alpha_s"] == b["alpha_s"]
    for k in ("s_body", "s_blade", "body_snr_measured_db", "sideband1_snr_measured_db", "body_snr_twin_db"):
        assert b[k] == pytest.approx(a[k], rel=1e-4, abs=1e-4), k
    assert abs(res[0, "garbled"]["body_snr_measured_db"] - res[0, "clean"]["body_snr_measured_db"]) > 0.5


def test_capped_and_segmented_fits_match_the_full_one(drone):
    """The search on 16 of 72 fold-A CPIs, synthesised only around them, lands within
    a small margin of the search on all of fold A with whole-record synthesis."""
    fl, log, rev = drone
    full_cfg = calibration.CalibrationConfig(max_fit_cpis=0, **FAST)
    # extensions (none in use) force whole-record synthesis
    _, full = calibration.fit_twin(
        fl, rev, log, spec_cfg=SPEC, cfg=full_cfg, seed=5, extensions=lambda s: ModelExtensions()
    )
    _, seg = calibration.fit_twin(fl, rev, log, spec_cfg=SPEC, cfg=full_cfg, seed=5)
    assert seg["alpha_s"] == full["alpha_s"]
    assert seg["s_body"] == pytest.approx(full["s_body"], rel=2e-3)
    assert seg["s_blade"] == pytest.approx(full["s_blade"], rel=2e-3)
    iq, cap = calibration.fit_twin(fl, rev, log, spec_cfg=SPEC, cfg=replace(full_cfg, max_fit_cpis=16), seed=5)
    alphas = full_cfg.alphas()
    assert abs(np.searchsorted(alphas, cap["alpha_s"]) - np.searchsorted(alphas, full["alpha_s"])) <= 1
    # both stop within tolerance_db / 4 (0.5 dB) of their targets
    assert abs(20 * np.log10(cap["s_body"] / full["s_body"])) < 0.6
    assert abs(20 * np.log10(cap["s_blade"] / full["s_blade"])) < 0.6
    assert cap["status"] == "ok" and abs(cap["body_error_db"]) < 1.0 and abs(cap["sideband1_error_db"]) < 1.0
    assert iq.dtype == np.complex64 and len(iq) == len(fl.iq)
