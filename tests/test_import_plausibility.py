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


@pytest.mark.parametrize("opts, n, must", [
    (_with(carrier_hz="3.3"), 4096, ("carrier_hz", "3.3 Hz", "looks like GHz typed as Hz", "--force")),
    (_with(carrier_hz="5800"), 4096, ("carrier_hz", "looks like MHz typed as Hz")),
    (_with(carrier_hz="9e12"), 4096, ("carrier_hz", "9e+12 Hz", "100 MHz-300 GHz")),
    (_with(prf_hz="7.3"), 4096, ("prf_hz", "7.3 Hz", "looks like kHz typed as Hz")),
    (_with(prf_hz="5e7"), 4096, ("prf_hz", "5e+07 Hz")),
    (GOOD, 100, ("duration", "100 pulses", "0.0137 s", "shorter than one CPI", "4096 pulses")),
    (_with(prf_hz="140", carrier_hz="24e9"), 4096, ("prf_hz", "slowest plausible tips", "0.19 m blades",
                                                    "check prf_hz and carrier_hz")),
], ids=["ghz-as-hz", "mhz-as-hz", "carrier-too-high", "khz-as-hz", "prf-too-high", "shorter-than-a-cpi",
        "tips-fold-far"])
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
    rc, err = run_cli(capsys, ["import", _npy(tmp_path, 2048), *_with(prf_hz="2000", carrier_hz="24e9"),
                               "--out", out, "--quiet"])
    assert rc == 0, err
    assert "plausibility_warnings" not in read_flight(out).attrs


def test_every_missing_parameter_is_named_at_once(tmp_path, capsys):
    m = write_sigmf(tmp_path, "r", _iq(), sample_rate=None)
    rc, err = run_cli(capsys, ["import", m, "--target", "drone", "--drone-model", "x", "--out", tmp_path / "s.zarr"])
    one_line(rc, err, "prf_hz, radar_id, n_motors, n_blades, blade_length_m, track", "--prf-hz", "--radar-id",
             "--n-motors", "--n-blades", "--blade-length-m", "--track CSV or --range-m")


def test_one_missing_parameter_reads_as_before(tmp_path, capsys):
    m = write_sigmf(tmp_path, "r", _iq())
    rc, err = run_cli(capsys, ["import", m, "--target", "bird", "--range-m", "500", "--out", tmp_path / "s.zarr"])
    one_line(rc, err, "radar_id: missing: not in the file's metadata, a sidecar or the options",
             "(expected --radar-id or the sidecar key radar_id)")
