"""``microdoppler simulate``: stores, speeds, noise, tracks and one-line errors."""

from __future__ import annotations

import numpy as np
import pytest

from microdoppler.cli import main
from microdoppler.io.flightzarr import read_flight
from microdoppler.spectra.spectrogram import SpectrogramConfig, spectrogram

LAM = 299792458 / 1.35e9


def _sim(tmp_path, name, *extra):
    out = tmp_path / f"{name}.zarr"
    rc = main(["simulate", "--out", str(out), "--quiet", *extra])
    assert rc == 0
    return read_flight(out)


def test_simulate_constant_speeds_writes_valid_store_with_lines(tmp_path):
    f = _sim(
        tmp_path,
        "c",
        "--motor-hz",
        "85,90,95,100",
        "--duration-s",
        "1.5",
        "--range-m",
        "400",
        "--radial-velocity-mps",
        "-4",
        "--seed",
        "3",
    )
    assert f.attrs["n_motors"] == 4 and f.attrs["target"] == "drone"
    assert len(f.iq) == int(round(1.5 * 7300))
    spec = spectrogram(f.iq, f.prf_hz, SpectrogramConfig(n_bins=0, highpass_hz=0))
    p = spec.power_db.mean(axis=0)
    f_body = 2 * 4 / LAM
    assert abs(spec.doppler_hz[np.argmax(p)] - f_body) <= spec.bin_hz
    np.testing.assert_allclose(f.motors_rpm[0], [85 * 60, 90 * 60, 95 * 60, 100 * 60])
    np.testing.assert_allclose(f.track_radial_velocity_mps, -4.0, atol=1e-9)


def test_simulate_same_seed_reproducible(tmp_path):
    a = _sim(tmp_path, "a", "--motor-hz", "80,80", "--duration-s", "0.6", "--snr-db", "10", "--seed", "9")
    b = _sim(tmp_path, "b", "--motor-hz", "80,80", "--duration-s", "0.6", "--snr-db", "10", "--seed", "9")
    np.testing.assert_array_equal(a.iq, b.iq)


def test_simulate_dielectric_blades_scale_the_blade_echo(tmp_path):
    """--blade-scattering dielectric: a 0.06 m blade's echo is (0.06 / 0.19)^2 of eq. (1)'s
    at 1.35 GHz (the body is untouched); the choice is recorded in the store."""
    args = ["--motor-hz", "90,95", "--duration-s", "0.5", "--blade-length-m", "0.06", "--seed", "2"]
    wire = _sim(tmp_path, "wire", *args, "--s-body", "0")
    diel = _sim(tmp_path, "diel", *args, "--s-body", "0", "--blade-scattering", "dielectric")
    ratio = np.sqrt(np.mean(np.abs(diel.iq) ** 2) / np.mean(np.abs(wire.iq) ** 2))
    assert ratio == pytest.approx((0.06 / 0.19) ** 2, rel=1e-4)
    assert diel.attrs["simulation"]["blade_scattering"] == "dielectric"
    assert wire.attrs["simulation"]["blade_scattering"] == "thin_wire"


def test_snr_is_body_power_over_noise_power_per_pulse(tmp_path):
    args = ["--motor-hz", "90", "--duration-s", "2", "--s-body", "0.5", "--s-blade", "0", "--seed", "4"]
    clean = _sim(tmp_path, "clean", *args)
    noisy = _sim(tmp_path, "noisy", *args, "--snr-db", "6")
    noise = noisy.iq.astype(np.complex128) - clean.iq
    snr = 10 * np.log10(np.mean(np.abs(clean.iq) ** 2) / np.mean(np.abs(noise) ** 2))
    assert abs(snr - 6.0) < 0.1
    assert noisy.attrs["simulation"]["snr_db"] == 6.0


def test_simulate_from_motor_log_and_track(tmp_path, ulog_path):
    track = tmp_path / "track.csv"
    t = np.linspace(0, 6, 13)
    np.savetxt(
        track, np.column_stack([t, 900 - 3 * t + 0.2 * t**2]), delimiter=",", header="time_s,range_m", comments=""
    )
    f = _sim(
        tmp_path,
        "log",
        "--motor-log",
        str(ulog_path),
        "--track",
        str(track),
        "--duration-s",
        "5",
        "--variant",
        "per_cpi",
        "--alpha",
        "0.005",
    )
    assert len(f.iq) == 5 * 7300 and f.motors_rpm.shape == (127, 4)
    np.testing.assert_allclose(f.track_range_m, 900 - 3 * f.track_time_s + 0.2 * f.track_time_s**2, atol=0.05)


def test_simulate_blade_amplitudes_put_a_line_at_the_rotation_rate(tmp_path):
    """--blade-amplitudes 1,0.5: one motor at 90 rev/s, body at rest, no body echo; the
    rotation-rate line (90 Hz, odd) appears beside the blade-passing line (180 Hz) only
    with unequal blades, and the amplitudes are recorded in the store."""
    args = ["--motor-hz", "90", "--duration-s", "2", "--s-body", "0", "--radial-velocity-mps", "0", "--seed", "2"]
    equal = _sim(tmp_path, "equal", *args)
    weak = _sim(tmp_path, "weak", *args, "--blade-amplitudes", "1,0.5")
    assert weak.attrs["simulation"]["blade_amplitudes"] == [1.0, 0.5]
    assert "blade_amplitudes" not in equal.attrs["simulation"]

    def line_db(fl, f0):
        spec = spectrogram(fl.iq, fl.prf_hz, SpectrogramConfig(n_bins=0, highpass_hz=0))
        p = spec.power_db.mean(axis=0)
        return float(np.max(p[np.abs(spec.doppler_hz - f0) <= 2 * spec.bin_hz]))

    for fl in (equal, weak):  # the blade-passing line is there either way
        assert line_db(fl, 180.0) > line_db(fl, 135.0) + 60
    assert line_db(weak, 90.0) > line_db(weak, 135.0) + 60  # rotation-rate line, far above leakage
    assert line_db(weak, 90.0) > line_db(equal, 90.0) + 60  # ... and absent for equal blades


@pytest.mark.parametrize(
    "args, field",
    [
        (["--motor-hz", "85,90", "--blade-amplitudes", "1,0.5,1"], "--blade-amplitudes"),
        (["--motor-hz", "85,90", "--blade-amplitudes", "1,-0.5"], "--blade-amplitudes"),
        (["--motor-hz", "85,90,95", "--blade-amplitudes", "1,1;1,0.5"], "--blade-amplitudes"),
        (["--motor-hz", "85,90", "--blade-amplitudes", "1,x"], "--blade-amplitudes"),
        (["--motor-hz", "85,x"], "--motor-hz"),
        (["--motor-hz", "85", "--alpha", "-1"], "--alpha"),
        (["--motor-hz", "85", "--range-m", "10", "--radial-velocity-mps", "-20", "--duration-s", "1"], "--range-m"),
        (["--motor-hz", "85", "--snr-db", "10", "--s-body", "0"], "--s-body"),
        (["--motor-log", "nonexistent.csv"], "file"),
    ],
)
def test_simulate_bad_input_one_line_nothing_written(tmp_path, capsys, args, field):
    out = tmp_path / "bad.zarr"
    rc = main(["simulate", "--out", str(out), "--quiet", *args])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and field in err and "Traceback" not in err, err
    assert not out.exists()


def test_simulate_bad_track(tmp_path, capsys):
    track = tmp_path / "t.csv"
    track.write_text("time_s,range_m\n0,500\n1,nan\n")
    rc = main(["simulate", "--out", str(tmp_path / "x.zarr"), "--motor-hz", "80", "--track", str(track)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and str(track) in err and "range_m" in err


@pytest.mark.slow
def test_figures_write_pngs(tmp_path, rng, ulog_path):
    import matplotlib.pyplot as plt

    from microdoppler import figures
    from microdoppler.io.motorlog import MotorLog

    t = np.arange(0, 6, 1 / 30)
    log = MotorLog(t, (4800 + np.cumsum(rng.normal(0, 20, (len(t), 4)), axis=0)).astype(np.float32), "synthetic")
    out8 = figures.fig8(tmp_path / "f8.png", motor_log=log)
    out2 = figures.fig2(tmp_path / "f2.png", ulog_path=ulog_path, duration_s=3.0)
    for p in (out8, out2):
        assert p.exists() and p.stat().st_size > 10_000 and p.read_bytes()[:4] == b"\x89PNG"
    fig, ax = plt.subplots()
    spec = spectrogram(np.exp(2j * np.pi * 100 * np.arange(8192) / 7300).astype(np.complex64), 7300.0)
    im = figures.plot_spectrogram(ax, spec, dynamic_range_db=40, title="x")
    lo, hi = im.get_clim()
    assert hi - lo == 40 and ax.get_ylabel().startswith("Doppler")
    plt.close(fig)


def test_fig8_track_stays_away_from_radar_for_paper_length_logs():
    """The paper profile's logs run ~200 s; Fig. 8's approaching track (4 m/s on
    average) must keep a positive range over the whole log (it went negative after
    150 s from 600 m)."""
    from microdoppler import figures

    for dur in (6.0, 150.0, 400.0):
        tr = figures._wavy_track(dur)
        assert tr.time_s[-1] == pytest.approx(dur)
        assert np.all(tr.range_m > 50.0), dur
