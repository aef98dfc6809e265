"""``microdoppler import`` refuses an implausible declared set-up (one line, exit 2,
naming the field and what the recording shows), writes it with ``--force`` and the
warning stored, and names every missing required parameter at once."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import one_line, run_cli
from test_import import DRONE_OPTS, _iq, write_sigmf


def _npy(d, n=4096):
    p = d / "r.npy"
    np.save(p, _iq(n))
    return p


GOOD = ["--prf-hz", "7300", "--carrier-hz", "1.35e9", "--range-m", "500", *DRONE_OPTS]


def _with(**kw):
    """GOOD with options replaced: ``_with(carrier_hz="3.3")``."""
    out = list(GOOD)
    for k, v in kw.items():
        out[out.index("--" + k.replace("_", "-")) + 1] = v
    return out


@pytest.mark.parametrize(
    "opts, n, must",
    [
        (_with(carrier_hz="3.3"), 4096, ("carrier_hz", "3.3 Hz", "looks like GHz typed as Hz", "--force")),
        (_with(carrier_hz="5800"), 4096, ("carrier_hz", "looks like MHz typed as Hz")),
        (_with(carrier_hz="9e12"), 4096, ("carrier_hz", "9e+12 Hz", "100 MHz-300 GHz")),
        (_with(prf_hz="7.3"), 4096, ("prf_hz", "7.3 Hz", "looks like kHz typed as Hz")),
        (_with(prf_hz="5e7"), 4096, ("prf_hz", "5e+07 Hz")),
        (GOOD, 100, ("duration", "100 pulses", "0.0137 s", "shorter than one CPI", "4096 pulses")),
        (
            _with(prf_hz="140", carrier_hz="24e9"),
            4096,
            ("prf_hz", "slowest plausible tips", "0.19 m blades", "check prf_hz and carrier_hz"),
        ),
    ],
    ids=[
        "ghz-as-hz",
        "mhz-as-hz",
        "carrier-too-high",
        "khz-as-hz",
        "prf-too-high",
        "shorter-than-a-cpi",
        "tips-fold-far",
    ],
)
def test_an_implausible_set_up_is_refused_in_one_line_and_nothing_is_written(tmp_path, capsys, opts, n, must):
    out = tmp_path / "s.zarr"
    rc, err = run_cli(capsys, ["import", _npy(tmp_path, n), *opts, "--out", out])
    one_line(rc, err, "r.npy", *must)
    assert not out.exists()


def test_the_100_pulse_array_of_0_02_s_is_refused(tmp_path, capsys):
    """The issue's 0.02 s array: 100 pulses at 5 kHz."""
    rc, err = run_cli(capsys, ["import", _npy(tmp_path, 100), *_with(prf_hz="5000"), "--out", tmp_path / "s.zarr"])
    one_line(rc, err, "duration", "100 pulses = 0.02 s", "2048 pulses = 0.41 s")


def test_force_writes_the_store_with_the_warning_stored_and_repeated(tmp_path, capsys):
    from microdoppler.cli import main
    from microdoppler.io.flightzarr import read_flight

    out = tmp_path / "s.zarr"
    rc, err = run_cli(capsys, ["import", _npy(tmp_path), *_with(carrier_hz="3.3"), "--force", "--out", out])
    assert rc == 0, err
    assert "warning:" in err and "carrier_hz: is 3.3 Hz: looks like GHz typed as Hz" in err
    (w,) = read_flight(out).attrs["plausibility_warnings"]
    assert w.startswith("carrier_hz: is 3.3 Hz: looks like GHz typed as Hz")
    assert main(["validate", str(out)]) == 0
    assert w in capsys.readouterr().err


def test_a_plausible_set_up_passes_silently(tmp_path, capsys):
    """24 GHz at a 2 kHz PRF folds the tips a few times (real set-ups do): accepted."""
    from microdoppler.io.flightzarr import read_flight

    out = tmp_path / "s.zarr"
    rc, err = run_cli(
        capsys, ["import", _npy(tmp_path, 2048), *_with(prf_hz="2000", carrier_hz="24e9"), "--out", out, "--quiet"]
    )
    assert rc == 0, err
    assert "plausibility_warnings" not in read_flight(out).attrs


def test_every_missing_parameter_is_named_at_once(tmp_path, capsys):
    m = write_sigmf(tmp_path, "r", _iq(), sample_rate=None)
    rc, err = run_cli(capsys, ["import", m, "--target", "drone", "--drone-model", "x", "--out", tmp_path / "s.zarr"])
    one_line(
        rc,
        err,
        "prf_hz, radar_id, n_motors, n_blades, blade_length_m, track",
        "--prf-hz",
        "--radar-id",
        "--n-motors",
        "--n-blades",
        "--blade-length-m",
        "--track CSV or --range-m",
    )


def test_one_missing_parameter_reads_as_before(tmp_path, capsys):
    m = write_sigmf(tmp_path, "r", _iq())
    rc, err = run_cli(capsys, ["import", m, "--target", "bird", "--range-m", "500", "--out", tmp_path / "s.zarr"])
    one_line(
        rc,
        err,
        "radar_id: missing: not in the file's metadata, a sidecar or the options",
        "(expected --radar-id or the sidecar key radar_id)",
    )


# ---- checks against the recording itself (microdoppler.rotors.plausibility) -----------


def _drone_recording(d, case, *, log_rev_s=None, **declared):
    """Write ``case`` (tests/any_radar.py) as rec.npz + track.csv (+ motors.csv at
    ``log_rev_s`` on every motor) and return the import's argv, with ``declared``
    replacing the true set-up's fields."""
    from any_radar import make_recording

    flight, truth = make_recording(case)
    return _write(d, flight, log_rev_s=log_rev_s, **declared), truth


def _write(d, flight, *, log_rev_s=None, **declared):
    np.savez(d / "rec.npz", iq=flight.iq)
    track = d / "track.csv"
    rows = np.column_stack([flight.track_time_s, flight.track_range_m, flight.track_radial_velocity_mps])
    np.savetxt(track, rows, delimiter=",", header="time_s,range_m,radial_velocity_mps", comments="")
    a = {**{k: flight.attrs[k] for k in ("prf_hz", "carrier_hz", "n_motors", "n_blades", "blade_length_m")}, **declared}
    argv = [
        d / "rec.npz",
        "--target",
        "drone",
        "--radar-id",
        "r",
        "--drone-model",
        "d",
        "--track",
        track,
        *[x for k, v in a.items() for x in ("--" + k.replace("_", "-"), f"{v:.10g}")],
    ]
    if log_rev_s is not None:
        t = np.arange(0.0, len(flight.iq) / flight.attrs["prf_hz"] + 0.5, 0.04)
        cols = np.column_stack([t] + [np.full(len(t), 60.0 * log_rev_s)] * flight.attrs["n_motors"])
        np.savetxt(
            d / "motors.csv",
            cols,
            delimiter=",",
            comments="",
            header="time_s," + ",".join(f"m{i}" for i in range(flight.attrs["n_motors"])),
        )
        argv += ["--motor-log", d / "motors.csv"]
    return argv


def _stand(duration_s=4.0):
    """The docs' stand recording (docs/examples/make_stand_recording.py), shorter."""
    from microdoppler.examples import stand_case

    return stand_case(seed=7, duration_s=duration_s)


def test_lines_wider_than_any_plausible_tips_refuse_the_prf(tmp_path, capsys):
    """The stand recording with its PRF typed x5: its lines fill ±12.5 kHz, while 0.12 m
    tips at 3.3 GHz reach at most ±7.4 kHz below 240 m/s."""
    argv, _ = _drone_recording(tmp_path, _stand(), prf_hz=25000.0)
    rc, err = run_cli(capsys, ["import", *argv, "--out", tmp_path / "s.zarr"])
    one_line(
        rc,
        err,
        "prf_hz, carrier_hz:",
        "the spectrum's lines",
        "blade_length_m 0.12 m",
        "3.3 GHz",
        "check prf_hz, carrier_hz, blade_length_m",
    )
    assert not (tmp_path / "s.zarr").exists()


def test_a_body_line_away_from_the_tracks_doppler_refuses_prf_and_carrier(tmp_path, capsys):
    """A flying drone (1.3 GHz, 8.7 m/s) declared at twice its PRF: its body line stands
    at twice the Doppler the track gives."""
    from any_radar import draw_case

    case = draw_case(27, duration_s=3.0)
    argv, _ = _drone_recording(tmp_path, case, prf_hz=2 * case.prf_hz)
    rc, err = run_cli(capsys, ["import", *argv, "--out", tmp_path / "s.zarr"])
    one_line(
        rc,
        err,
        "prf_hz, carrier_hz:",
        "the body line stands at",
        "the track's radial velocity",
        "check prf_hz, carrier_hz (or the track)",
    )


@pytest.mark.parametrize(
    "declare, must",
    [
        (
            {"blade_length_m": 4.0},
            (
                "n_blades, blade_length_m, prf_hz:",
                "the motor log turns at 43.9 rev/s",
                "268 m/s, above a drone's 30-240 m/s",
            ),
        ),
        ({"blade_length_m": 0.4}, ("n_blades, blade_length_m, prf_hz:", "27 m/s, below a drone's 30-240 m/s")),
        (
            {"carrier_hz": 0.4},
            ("carrier_hz, blade_length_m, n_blades:", "the spectrum's lines reach ±424 Hz", "at most ±408 Hz"),
        ),
    ],
    ids=["tips-too-fast", "tips-too-slow", "lines-beyond-the-tips"],
)
def test_the_rotors_tips_at_the_logged_rate_must_be_plausible(tmp_path, capsys, declare, must):
    """A hovering drone (1.3 GHz, 0.24 m blades at 43.9 rev/s) with its motor log: a
    blade length or carrier off by a factor puts its tips outside a drone's speeds or
    its lines beyond the tips' Doppler."""
    from any_radar import draw_case

    case = draw_case(10, duration_s=3.0)
    argv, truth = _drone_recording(tmp_path, case, log_rev_s=43.85)
    assert abs(np.mean(truth["rev_s"]) - 43.85) < 0.05
    a = {"blade_length_m": case.blade_length_m, "carrier_hz": case.carrier_hz}
    for k, m in declare.items():
        argv[argv.index("--" + k.replace("_", "-")) + 1] = f"{a[k] * m:.10g}"
    rc, err = run_cli(capsys, ["import", *argv, "--out", tmp_path / "s.zarr"])
    one_line(rc, err, *must)


def test_force_stores_the_recordings_contradiction(tmp_path, capsys):
    from microdoppler.io.flightzarr import read_flight

    argv, _ = _drone_recording(tmp_path, _stand(), prf_hz=25000.0)
    rc, err = run_cli(capsys, ["import", *argv, "--force", "--quiet", "--out", tmp_path / "s.zarr"])
    assert rc == 0, err
    (w,) = read_flight(tmp_path / "s.zarr").attrs["plausibility_warnings"]
    assert w.startswith("prf_hz, carrier_hz: the spectrum's lines") and w in err


@pytest.mark.parametrize("which", ["any_radar hover, motor log", "any_radar flying", "stand", "gen_l", "gen_s"])
def test_a_true_set_up_from_each_generator_passes(tmp_path, capsys, which):
    from any_radar import draw_case
    from independent_generator import GenCase, make_flight

    if which.startswith("gen"):
        flight, _ = make_flight(GenCase(flight_id="g", seed=100, radar=which, duration_s=4.0))
        argv = _write(tmp_path, flight)
    else:
        case = {
            "any_radar hover, motor log": draw_case(10, duration_s=3.0),
            "any_radar flying": draw_case(27, duration_s=3.0),
            "stand": _stand(),
        }[which]
        argv, _ = _drone_recording(tmp_path, case, log_rev_s=43.85 if "log" in which else None)
    rc, err = run_cli(capsys, ["import", *argv, "--quiet", "--out", tmp_path / "s.zarr"])
    assert rc == 0 and not err, err


def test_an_order_another_blade_count_explains_names_n_blades():
    """The issue's stand recording declared with 3 blades instead of 2: the lines' comb
    read with 3 blades gives 107.6 rev/s, the order check lists 161.4 (what 2 blades
    give)."""
    from types import SimpleNamespace

    from microdoppler.rotors.plausibility import blade_count_hint

    order = {"ambiguous": True, "lines_rev_s": 107.6, "chosen_rev_s": 107.6, "alternatives_rev_s": [53.8, 161.4]}
    est = SimpleNamespace(n_blades=3, info={"order": order})
    hint = blade_count_hint(est)
    assert hint.startswith("n_blades:") and "161.4 rev/s" in hint and "read with 2 blades" in hint
    assert blade_count_hint(SimpleNamespace(n_blades=3, info={"order": {**order, "ambiguous": False}})) is None
    # half the rate: a sub-harmonic, no blade count
    assert (
        blade_count_hint(SimpleNamespace(n_blades=3, info={"order": {**order, "alternatives_rev_s": [53.8]}})) is None
    )
    # the order check chose what 3 blades read from a comb declared with 2
    chose = {"ambiguous": False, "lines_rev_s": 134.0, "chosen_rev_s": 89.3, "alternatives_rev_s": []}
    assert "read with 3 blades 89.3 rev/s, which the order check chose" in blade_count_hint(
        SimpleNamespace(n_blades=2, info={"order": chose})
    )


def test_fit_progress_names_each_pass_once():
    """The importer's progress: a pass ends with its last CPI; the next pass (the order
    check measuring again, even over more CPIs) is named, the first is not."""
    import io

    from microdoppler.commands.importer import FitProgress

    out = io.StringIO()
    p = FitProgress(out)
    for done, total in ((64, 120), (120, 120), (27, 28), (28, 28)):
        p(done, total)
    lines = out.getvalue().splitlines()
    assert [("pass 2" in ln) for ln in lines] == [False, False, True, True]
    assert lines[1].endswith("I/Q fit, 120 of 120 CPIs") and lines[3].endswith("28 of 28 CPIs")
