"""Rotor speeds from the radar (microdoppler.rotors.speed): HERM line spacing per CPI.

The flights and their truth per CPI: tests/rotor_flights.py (eq. (1), no emulator);
the I/Q fit's own tests: test_rotorfit.py.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.signal.windows import blackmanharris

from microdoppler.emulator import FlightSpec, emulate_flight
from microdoppler.io.flightzarr import Flight, read_flight, write_flight
from microdoppler.io.motorlog import read_motor_store
from microdoppler.rotors.fit import FitConfig
from microdoppler.rotors.speed import (
    RotorEstimate,
    RotorSpeedConfig,
    cpi_means_of_spline,
    departure_sigma,
    estimate_rotor_speeds,
    instants_from_cpi_means,
)
from rotor_flights import CARRIER, LAM, N_FFT, PRF, cpi_truth, rel_errors, synthetic_flight


@pytest.mark.slow
def test_constant_speeds_of_fig2b_give_each_rotor_and_the_herm_spacing():
    """Four rotors at 85, 90, 95, 100 rev/s (Fig. 2b): four separate lines, each rotor to
    better than 0.05 %, and a line spacing of B times the rotation rate (a steady signal:
    4 s, 13 CPIs, each asserted)."""
    speeds = np.array([85.0, 90.0, 95.0, 100.0])
    fl = synthetic_flight(np.tile(speeds, (int(4 * PRF), 1)), seed=11)
    est = estimate_rotor_speeds(fl)
    assert est.ok, est.reason
    assert est.valid.all() and est.separated.all()
    assert np.all(est.n_pairs >= 3)
    np.testing.assert_allclose(est.speeds_rev_s, np.tile(speeds, (len(est.time_s), 1)), rtol=5e-4)
    np.testing.assert_allclose(est.line_spacing_hz, 2 * speeds.mean(), rtol=5e-4)
    # the reported uncertainty is not wildly optimistic
    assert np.all(np.abs(est.speeds_rev_s - speeds) <= 4 * est.speeds_std_rev_s + 0.01)
    # the body Doppler is the centre of symmetry: -2 v / lambda
    np.testing.assert_allclose(est.body_hz, 2 * 5.0 / LAM, atol=1.0)


@pytest.mark.slow
def test_blade_count_sets_the_spacing_and_equal_rotors_share_one_line():
    """Three-blade rotors all at 60 rev/s: lines every 180 Hz, one line for all four rotors
    (a steady signal: 4 s, 13 CPIs, each asserted)."""
    fl = synthetic_flight(np.full((int(4 * PRF), 4), 60.0), n_blades=3, blade_length_m=0.15, seed=12)
    est = estimate_rotor_speeds(fl)
    assert est.ok, est.reason
    assert est.valid.all()
    assert np.all(est.n_lines == 1) and not est.separated.any()
    np.testing.assert_allclose(est.speeds_rev_s, 60.0, rtol=1e-3)
    np.testing.assert_allclose(est.line_spacing_hz, 180.0, rtol=1e-3)
    assert np.all(np.abs(est.common_rev_s - 60.0) <= 3 * est.common_std_rev_s)
    # wrong blade count: the same spacing read as a different speed (B f is what is measured)
    est2 = estimate_rotor_speeds(fl, n_blades=2)
    np.testing.assert_allclose(np.nanmedian(est2.common_rev_s), 90.0, rtol=1e-3)


@pytest.mark.slow
def test_ramping_speeds_of_close_rotors():
    """Rotors 2 % apart, all ramping 60 -> 80 rev/s over 8 s (they merge at the first
    harmonic and separate at higher ones)."""
    t = np.arange(int(8 * PRF)) / PRF
    rev = np.outer(60.0 + 20.0 * t / t[-1], [0.97, 0.99, 1.01, 1.03])
    fl = synthetic_flight(rev, snr_db=50.0, seed=13)
    est = estimate_rotor_speeds(fl)
    assert est.ok, est.reason
    truth = cpi_truth(t, rev, est.time_s)
    mean_err, rotor_err = rel_errors(est, truth)
    sel = est.valid & (est.n_pairs >= 2)
    assert sel.mean() > 0.8
    assert np.median(mean_err[sel]) < 0.003
    assert np.percentile(mean_err[sel], 95) < 0.01
    assert np.median(rotor_err[sel]) < 0.005


@pytest.mark.slow
def test_steady_rotors_a_bin_apart_are_within_one_percent_in_every_cpi():
    """The condition under which the 1 % target holds (docs/experiments.md): speeds
    steady within the CPI (here a 1 % wobble over 3 s) and the closest two rotors at
    least one STFT bin apart at the first harmonic (1.0 rev/s = 2 Hz = 1.1 bins)."""
    t = np.arange(int(10 * PRF)) / PRF
    rev = np.outer(1 + 0.01 * np.sin(2 * np.pi * t / 3.0), [58.0, 59.0, 61.5, 62.6])
    fl = synthetic_flight(rev, seed=21)
    est = estimate_rotor_speeds(fl)
    assert est.ok, est.reason
    truth = cpi_truth(t, rev, est.time_s)
    mean_err, rotor_err = rel_errors(est, truth)
    sel = est.valid & (est.n_pairs >= 2)
    assert sel.mean() > 0.9
    assert np.all(mean_err[sel] <= 0.01)
    assert np.median(rotor_err[sel]) < 0.003


def test_ambiguous_rotor_counts_report_an_honest_uncertainty():
    """Two rotors 0.1 rev/s apart never separate in the periodogram (their line's power
    swings with their phase, 0 to 4 times one rotor's) beside two that do: the rotor
    count per line is ambiguous and the periodogram's mean speed is off by up to ~2 %
    in some CPIs (as in the emulated tail, docs/experiments.md). Its reported
    uncertainty must say so: the error within 3 sigma in >= 85 % of the CPIs (it was
    68 % with the counts' sharp posterior, 91 % with the measured share scatter), and
    the CPIs off by more than 1 % flagged with sigma > 0.5 %."""
    t = np.arange(int(10 * PRF)) / PRF
    rev = np.outer(1 + 0.01 * np.sin(2 * np.pi * t / 3.0), [81.1, 82.7, 88.0, 88.1])
    fl = synthetic_flight(rev, seed=21)
    est = estimate_rotor_speeds(fl, config=RotorSpeedConfig(refine=False))
    assert est.ok, est.reason
    assert est.info["method"] == "herm-pairs/1" and est.info["n_cpi_refined"] == 0
    truth = cpi_truth(t, rev, est.time_s)
    mean_err, _ = rel_errors(est, truth)
    sel = est.valid & (est.n_pairs >= 2)
    assert sel.mean() > 0.9
    assert np.mean(mean_err[sel] <= 0.01) > 0.5
    z = np.abs(est.common_rev_s - truth.mean(axis=1)) / est.common_std_rev_s
    assert np.mean(z[sel] <= 3) >= 0.85
    rel_sd = est.common_std_rev_s / est.common_rev_s
    assert np.median(rel_sd[sel & (mean_err > 0.01)]) > 0.005
    with pytest.raises(ValueError, match="max_step_rel"):
        RotorSpeedConfig(max_step_rel=0.0)
    with pytest.raises(ValueError, match="min_power"):
        FitConfig(min_power=1.5)


@pytest.mark.slow
def test_cpis_without_a_pair_are_nan_and_left_out_of_the_log():
    """Blades visible for 3 s of 6 s: estimates there, NaN after (never a guess), and the
    motor log holds only the CPIs with an estimate."""
    fl = synthetic_flight(np.tile([78.0, 80.0, 83.0, 86.0], (int(6 * PRF), 1)), blades_until_s=3.0, seed=15)
    est = estimate_rotor_speeds(fl)
    assert est.ok, est.reason
    half = N_FFT / 2 / PRF
    before = est.time_s + half < 3.0  # CPI wholly before the blades fall silent
    after = est.time_s - half >= 3.0  # wholly after
    assert before.sum() >= 5 and after.sum() >= 5
    assert est.valid[before].all() and not est.valid[after].any()
    assert (est.n_pairs[after] == 0).all() and np.isnan(est.speeds_rev_s[after]).all()
    np.testing.assert_allclose(est.common_rev_s[before], 81.75, rtol=1e-3)
    log = est.to_motor_log()
    assert len(log.time_s) == int(est.valid.sum()) and np.isfinite(log.rpm).all()


# ---------------------------------------------------------------- emulated flights


@pytest.mark.slow
@pytest.mark.parametrize("model, seed", [("inspire2", 101), ("matrice300", 202)])
def test_emulated_flights_within_one_percent_where_two_pairs_show(model, seed):
    """The issue's target: within 1 % wherever two or more sideband pairs are visible.
    Emulated flights (gusty motor dynamics, several % speed change within a CPI, close
    rotors interfering): the mean rotor speed is within 1 % in most CPIs (the
    periodogram alone 79-87 % in benchmarks/eval_rotorspeed.py, median 0.26 %, its
    tail the rotor count per merged line; with the I/Q fit ~96 %, median ~0.02 %),
    the ranked rotors ~0.4 %."""
    # the paper text's short-range sidebands (3-8 dB per harmonic; the world's own draw
    # since world v2 spans 4-16 dB, and its steep flights show fewer pairs)
    spec = FlightSpec(
        f"t_{model}",
        "drone",
        drone_model=model,
        radar_id="radar1",
        duration_s=15.0,
        mean_range_m=1200.0,
        snr_db=50.0,
        seed=seed,
        harmonic_falloff_db=5.5,
    )
    fl, _ = emulate_flight(spec)
    est = estimate_rotor_speeds(fl)
    assert est.ok, est.reason
    truth = cpi_truth(fl.motors_time_s, fl.motors_rpm.astype(float) / 60.0, est.time_s)
    mean_err, rotor_err = rel_errors(est, truth)
    sel = est.valid & (est.n_pairs >= 2)
    assert sel.mean() > 0.8, f"only {sel.sum()} of {len(sel)} CPIs with >= 2 pairs"
    assert np.median(mean_err[sel]) < 0.002
    assert np.mean(mean_err[sel] <= 0.01) > 0.85
    assert np.percentile(mean_err[sel], 90) < 0.025
    assert np.median(rotor_err[sel]) < 0.012
    # the uncertainty: the error within 2 sigma in most CPIs (95 % in benchmarks/
    # eval_rotorspeed.py), and sigma not uselessly wide (the errors are a sharp core
    # plus a tail, so the median error sits at 0.1-0.5 sigma)
    z = np.abs(est.common_rev_s - truth.mean(axis=1))[sel] / est.common_std_rev_s[sel]
    assert np.mean(z <= 2) >= 0.85
    assert 0.1 < np.median(z) < 1.8


@pytest.mark.slow
def test_mini_gives_no_estimate_with_a_reason():
    """The Mini's 0.06 m blades show no sideband pair at L-band: no estimate, never a guess."""
    fl, _ = emulate_flight(
        FlightSpec(
            "t_mini", "drone", drone_model="mini2", radar_id="radar1", duration_s=12.0, mean_range_m=600.0, seed=303
        )
    )
    est = estimate_rotor_speeds(fl)
    assert not est.ok
    assert "sideband pair" in est.reason and f"of {len(est.time_s)} CPIs" in est.reason
    assert np.isnan(est.speeds_rev_s).all() and np.isnan(est.common_rev_s).all()
    with pytest.raises(ValueError, match="no rotor-speed estimate"):
        est.to_motor_log()


@pytest.mark.slow
def test_noise_and_birds_give_no_estimate(rng):
    # white noise labelled as a drone
    n = int(10 * PRF)
    iq = ((rng.standard_normal(n) + 1j * rng.standard_normal(n)) / np.sqrt(2)).astype(np.complex64)
    iq += np.exp(2j * np.pi * 60.0 * np.arange(n) / PRF).astype(np.complex64) * 30  # a bare body line
    tt = np.linspace(0, n / PRF, 20)
    attrs = dict(
        schema="flight-zarr/1",
        flight_id="noise",
        target="drone",
        radar_id="r",
        prf_hz=PRF,
        carrier_hz=CARRIER,
        drone_model="x",
        n_motors=4,
        n_blades=2,
        blade_length_m=0.19,
    )
    v = -60.0 * LAM / 2
    est = estimate_rotor_speeds(Flight(attrs, iq, tt, 1000 + v * tt, np.full(20, v)))
    assert not est.ok and est.reason.startswith("no sideband pair above the noise: 0 of")
    # a flock of birds, labelled as a drone: wing beats are no HERM comb
    fl, _ = emulate_flight(
        FlightSpec(
            "t_birds", "bird", bird_kind="small_flock", radar_id="radar1", duration_s=12.0, mean_range_m=800.0, seed=404
        )
    )
    assert estimate_rotor_speeds(fl).reason == "target is 'bird': no rotors"
    fl.attrs.update(target="drone", drone_model="x", n_motors=4, n_blades=2, blade_length_m=0.19)
    est = estimate_rotor_speeds(fl)
    assert not est.ok and np.isnan(est.common_rev_s).all()


def test_short_flight_and_bad_arguments():
    fl = synthetic_flight(np.full((3000, 4), 80.0))
    est = estimate_rotor_speeds(fl)
    assert not est.ok and "shorter than one CPI" in est.reason and len(est.time_s) == 0
    with pytest.raises(ValueError, match="n_fft"):
        estimate_rotor_speeds(fl, n_fft=1001)
    with pytest.raises(ValueError, match="min_rev_s"):
        RotorSpeedConfig(min_rev_s=300.0, max_rev_s=20.0)


# ---------------------------------------------------------------- storage


@pytest.mark.slow
def test_motor_log_and_flight_store_round_trip(tmp_path):
    t = np.arange(int(3 * PRF)) / PRF
    rev = np.outer(70.0 + 5.0 * t / t[-1], [0.94, 0.98, 1.02, 1.06])
    fl = synthetic_flight(rev, seed=14)
    est = estimate_rotor_speeds(fl)
    assert est.ok, est.reason
    log = est.to_motor_log()
    v = est.valid
    np.testing.assert_array_equal(log.time_s, est.time_s[v])
    assert log.rpm.shape == (int(v.sum()), 4) and log.rpm.dtype == np.float32
    # the rows are instants whose spline has the estimates as its CPI means
    np.testing.assert_allclose(
        cpi_means_of_spline(log.time_s, log.rev_s.astype(float), log.time_s, N_FFT, PRF), est.speeds_rev_s[v], rtol=1e-5
    )
    np.testing.assert_allclose(est.to_motor_log(cpi_means=True).rev_s, est.speeds_rev_s[v], rtol=1e-6)
    common = est.to_motor_log(per_motor=False, cpi_means=True)
    np.testing.assert_allclose(common.rev_s, np.repeat(est.common_rev_s[v, None], 4, 1), rtol=1e-6)
    store = write_flight(tmp_path / "f.zarr", est.with_flight(fl))
    back = read_flight(store)
    assert back.attrs["motors_source"] == "radar"
    meta = back.attrs["motors_radar"]
    assert meta["method"] == "herm-pairs+iq-fit/2" and np.shape(meta["rpm_std"]) == (int(v.sum()), 4)
    assert len(meta["n_pairs"]) == int(v.sum()) and meta["rows"].startswith("cubic-spline nodes")
    # the I/Q fit's power balance per row, where the rows' uncertainty comes from
    assert len(meta["balance"]) == int(v.sum())
    assert all(b is None or 0.0 <= b <= 1.0 for b in meta["balance"])
    np.testing.assert_allclose([np.nan if b is None else b for b in meta["balance"]], est.balance[v], atol=5e-4)
    assert est.store_attrs(cpi_means=True)["motors_radar"]["rows"].startswith("the estimates")
    np.testing.assert_allclose(back.motors_rpm, log.rpm)
    read_motor_store(store)  # passes the motor-log checks (plausible speeds, increasing times)


def test_motor_log_rows_are_instants_whose_cpi_means_are_the_estimates():
    """A manoeuvre (speed +-4 % at 1 Hz plus a ramp): the CPI means of the true
    history smooth its curvature; the log's rows recovered from them lie at the true
    instantaneous speeds, and the spline a twin drives its rotors with (natural cubic
    through the rows) has the measured CPI means, which the means themselves do not."""
    prf, n_fft = PRF, N_FFT
    hop = n_fft // 2
    t_f = np.arange(int(12 * prf)) / prf
    v = 80.0 + 3.2 * np.sin(2 * np.pi * 1.0 * t_f + 0.4) + 0.5 * t_f
    t = (np.arange(1 + (len(t_f) - n_fft) // hop) * hop + n_fft / 2) / prf
    w = blackmanharris(n_fft, sym=False) ** 2
    means = np.array([np.sum(w * v[i * hop : i * hop + n_fft]) / w.sum() for i in range(len(t))])[:, None]
    x = instants_from_cpi_means(t, means, n_fft, prf)
    true_at = np.interp(t, t_f, v)[:, None]
    inner = slice(2, -2)  # the ends hold the curve flat, as the sampling does
    err_means = np.abs(means - true_at)[inner].max()
    err_x = np.abs(x - true_at)[inner].max()
    assert err_means > 0.15  # rev/s: the means miss the peaks by ~0.25 %
    assert err_x < 0.25 * err_means
    np.testing.assert_allclose(cpi_means_of_spline(t, x, t, n_fft, prf), means, rtol=1e-6)
    assert np.abs(cpi_means_of_spline(t, means, t, n_fft, prf) - means)[inner].max() > 0.15


@pytest.mark.slow
def test_import_estimate_motors_then_diagnose_reports_lag_and_scale_untestable(tmp_path, capsys):
    """A drone recording without a log: `import --estimate-motors` stores the radar's
    rotor speeds (motors_source radar); the diagnosis runs on them and reports the
    motor-log causes as untestable with that reason."""
    from conftest import run_cli
    from microdoppler.diagnosis import diagnose
    from microdoppler.emulator.world import FlightSpec, emulate_flight
    from microdoppler.io.flightzarr import read_flight

    # 12 s: 41 CPIs, enough for the diagnosis's two held-out folds (>= 20 CPIs); the
    # median speed 0.1 % from the truth (9 s: 1.5 %, too near the 2 % asked)
    f, _ = emulate_flight(
        FlightSpec("est1", "drone", drone_model="inspire2", duration_s=12.0, snr_db=44.0, mean_range_m=1000.0, seed=101)
    )
    np.save(tmp_path / "est1.npy", f.iq)
    np.save(tmp_path / "est1_bg.npy", f.background_iq)
    pd.DataFrame(
        {"time_s": f.track_time_s, "range_m": f.track_range_m, "radial_velocity_mps": f.track_radial_velocity_mps}
    ).to_csv(tmp_path / "t.csv", index=False)
    out = tmp_path / "est1.zarr"
    rc, err = run_cli(
        capsys,
        [
            "import",
            tmp_path / "est1.npy",
            "--prf-hz",
            f.prf_hz,
            "--carrier-hz",
            f.carrier_hz,
            "--radar-id",
            "radar1",
            "--target",
            "drone",
            "--drone-model",
            "inspire2",
            "--n-motors",
            "4",
            "--n-blades",
            "2",
            "--blade-length-m",
            "0.19",
            "--track",
            tmp_path / "t.csv",
            "--background",
            tmp_path / "est1_bg.npy",
            "--estimate-motors",
            "--out",
            out,
            "--quiet",
        ],
    )
    assert rc == 0, err
    assert "rotor speeds from the radar" in err
    g = read_flight(out)
    assert g.attrs["motors_source"] == "radar" and g.has_motor_log
    method = g.attrs["motors_radar"]["method"]  # the method printed is the method stored
    assert f"method {method}" in err and err.count("method ") == 1, err
    true_rev_s = np.median(f.motors_rpm) / 60
    assert np.median(g.motors_rpm) / 60 == pytest.approx(true_rev_s, rel=0.02)
    rep = diagnose([out], tmp_path / "r.json", config={"figures": False}, log=lambda m: None)
    (e,) = rep["flights"]
    assert e["cause"] != "skipped", e.get("reason")
    for name in ("motor_log_lag", "motor_speed_scale"):
        t = e["evidence"]["tests"][name]
        assert not t["testable"] and "motors_source is radar" in t["reason"]


def test_a_cpi_that_departs_from_both_neighbours_carries_the_departure_in_its_sigma():
    """Step 11: the rotor group's speed changes by at most ``max_step_rel`` per hop, so a
    CPI whose mean departs from the median of its neighbours on both sides by more than
    ``smear_rel`` read a comb they did not (here 5/4 of theirs, as on eval_any_radar's
    any1041); its sigma then covers the departure. A steady ramp of 5 % per hop, the
    first and last CPIs (one side only) and a CPI beside a gap keep their sigma."""
    cfg = RotorSpeedConfig()
    n, M = 12, 4
    t = np.arange(n) * 0.3
    common = 100.0 * 1.05 ** np.arange(n)  # steady: 5 % per hop (< max_step_rel)
    truth = common.copy()
    common[5] *= 1.25  # a 5/4 comb in one CPI
    common[9] = np.nan  # a CPI without an estimate
    sd = 0.004 * common
    speeds = np.repeat(common[:, None], M, axis=1)
    est = RotorEstimate(
        "f",
        t,
        speeds.copy(),
        np.repeat(sd[:, None], M, axis=1),
        common.copy(),
        sd.copy(),
        np.full(n, 3),
        np.full(n, M),
        np.zeros(n),
        M,
        2,
        4096,
        None,
        {},
    )
    assert departure_sigma(est, cfg.smear_rel) == 1
    assert est.info["n_cpi_departing"] == 1
    assert "1 CPIs depart from both neighbours by over 12 %" in est.summary()
    z = np.abs(est.common_rev_s - truth) / est.common_std_rev_s
    assert z[5] <= 2 < abs(common[5] - truth[5]) / sd[5]  # covered now, not before
    keep = np.isfinite(common) & (np.arange(n) != 5)
    np.testing.assert_array_equal(est.common_std_rev_s[keep], sd[keep])
    assert np.all(est.speeds_std_rev_s[5] >= 0.2 * truth[5])


def _estimate(speeds, sds, info=None):
    from microdoppler.rotors.speed import RotorEstimate

    n, m = speeds.shape
    t = np.arange(n) * 0.28
    common, common_sd = speeds.mean(axis=1), sds.mean(axis=1)
    ones = np.ones(n, int)
    return RotorEstimate(
        "x", t, speeds, sds, common, common_sd, 2 * ones, m * ones, 0 * t, m, 2, 4096, None, info or {}
    )


def test_recording_mean_sigma_is_the_cpis_with_overlap_scatter_and_the_methods_difference():
    """recording_means: steady ranks whose CPIs scatter as their sigma says get about
    sqrt(2) x the independent mean's sigma (overlap); the two methods' difference joins
    in quadrature; a comb misread on one side in a third of the CPIs pulls the mean
    from the median, and the sigma covers the truth where the naive one does not."""
    from microdoppler.rotors.speed import RotorSpeedConfig, recording_means

    factor = RotorSpeedConfig().overlap_variance_factor

    rng = np.random.default_rng(3)
    n, sd = 40, 0.5
    truth = np.array([70.0, 72.0, 74.0, 76.0])
    speeds = truth + rng.normal(0.0, sd, (n, 4))
    speeds.sort(axis=1)
    sds = np.full((n, 4), sd)
    mean, std = recording_means(_estimate(speeds, sds))
    naive = sd / np.sqrt(n)
    assert np.allclose(mean, speeds.mean(axis=0))
    # the CPIs scatter about as their sigma says: at most a little excess
    assert np.all(std >= np.sqrt(factor) * naive - 1e-12)
    assert np.all(std <= 1.5 * np.sqrt(factor) * naive)
    # the methods' difference joins in quadrature
    diff = [0.3, -0.2, 0.0, 0.1]
    _, std_d = recording_means(_estimate(speeds, sds, {"method_diff_rev_s": diff}))
    assert np.allclose(std_d, np.sqrt(std**2 + np.square(diff)))
    # a comb misread in a third of the CPIs (every rank 4 rev/s high there): the naive
    # sigma excludes the truth, the recording mean's covers it
    bad = speeds.copy()
    bad[rng.uniform(size=n) < 0.33] += 4.0
    mean_b, std_b = recording_means(_estimate(bad, sds))
    err = np.abs(mean_b - truth)
    assert np.all(err > 2 * naive)
    assert np.all(err <= 2 * std_b)
    # no estimate: NaN
    from microdoppler.rotors.speed import _no_estimate

    m0, s0 = recording_means(_no_estimate("x", 5, np.arange(5.0), 4, 2, 4096, "none"))
    assert np.all(np.isnan(m0)) and np.all(np.isnan(s0))
