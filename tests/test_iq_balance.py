"""The import's I/Q balance check measures the receiver, not the target.

A rotor seen with its body at 0 Hz (hovering, on a stand, a staring radar) has a
mirror-symmetric spectrum by nature: measured on the target, a balanced digital-I/Q
recording read like a real-valued one ("image rejection 11.9 dB"). Here the
signatures come from a small generator of this file (point scatterers along the
blades, numpy only; nothing from the package's emulator or synthesis), at the
issue's radar (3.3 GHz, 5 kHz), and a receiver imbalance ``I + j g (Q cos phi + I
sin phi)`` is applied to everything the receiver recorded (target and background).

- hovering, balanced: no warning; without a background "not measurable";
- hovering with 1 dB or 5 deg imbalance and a background (or a target-free stretch
  of the recording): warned, measured there;
- flying with 1 dB or 5 deg imbalance: warned, measured on the body line's image;
  flying and balanced: no warning.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from conftest import one_line, run_cli
from microdoppler.importing.iqbalance import IQBalanceSettings, mirror_balance
from microdoppler.io.flightzarr import read_flight

C_MPS = 299792458.0
IMAGE_REJECTION_WARN_DB = IQBalanceSettings().image_rejection_warn_db
PRF_HZ, CARRIER_HZ, DURATION_S = 5000.0, 3.3e9, 8.0
OPTS = [
    "--prf-hz",
    str(PRF_HZ),
    "--carrier-hz",
    str(CARRIER_HZ),
    "--radar-id",
    "s_band",
    "--target",
    "drone",
    "--drone-model",
    "quad",
    "--n-motors",
    "4",
    "--n-blades",
    "2",
    "--blade-length-m",
    "0.1",
]


def signature(seed: int, *, speed_mps: float = 0.0, target_from_s: float = 0.0):
    """A quadcopter (body 1.0, four two-blade rotors of 0.1 m at 150-171 rev/s, ten
    points of 0.1 per blade) at 60 m, plus static clutter and white noise, slow time at
    5 kHz; and a target-free background of the same cell (its own clutter phase
    and noise). ``speed_mps``: dR/dt; ``target_from_s``: the target appears then."""
    rng = np.random.default_rng(seed)
    lam = C_MPS / CARRIER_HZ
    t = np.arange(int(DURATION_S * PRF_HZ)) / PRF_HZ
    r = 60.0 + speed_mps * t
    z = np.exp(-4j * np.pi * r / lam)
    radii = np.linspace(0.01, 0.1, 10)
    for k, rate in enumerate((150.0, 157.0, 164.0, 171.0)):
        th0 = rng.uniform(0, 2 * np.pi)
        for b in range(2):
            th = 2 * np.pi * rate * t + th0 + np.pi * b
            d = radii[:, None] * np.cos(th)[None, :] * np.cos(np.radians(10))
            z = z + 0.1 * np.exp(-4j * np.pi * (r + 0.05 * (k - 1.5) + d) / lam).sum(axis=0)
    z = np.where(t >= target_from_s, z, 0)

    def clutter_and_noise():
        return 30 * np.exp(1j * rng.uniform(0, 2 * np.pi)) + 0.02 * (
            rng.standard_normal(len(t)) + 1j * rng.standard_normal(len(t))
        )

    return z + clutter_and_noise(), clutter_and_noise(), t


def receiver(z, gain_db=0.0, phase_deg=0.0):
    """I/Q imbalance: Q scaled by 10^(-gain_db/20) and rotated by phase_deg into I."""
    g, ph = 10 ** (-gain_db / 20), np.radians(phase_deg)
    return (z.real + 1j * g * (z.imag * np.cos(ph) + z.real * np.sin(ph))).astype(np.complex64)


def irr_db(gain_db, phase_deg):
    g, ph = 10 ** (-gain_db / 20), np.radians(phase_deg)
    return 10 * np.log10((1 + 2 * g * np.cos(ph) + g * g) / (1 - 2 * g * np.cos(ph) + g * g))


def run_import(capsys, d, z, *extra, bg=None):
    np.save(d / "rec.npy", z)
    argv = ["import", d / "rec.npy", *OPTS, "--out", d / "rec.zarr", *extra]
    if bg is not None:
        np.save(d / "bg.npy", bg)
        argv += ["--background", d / "bg.npy"]
    rc, err = run_cli(capsys, argv)
    assert rc == 0, err
    warns = [ln for ln in err.splitlines() if ln.startswith("warning:")]
    return read_flight(d / "rec.zarr").attrs["import"], warns, err


@pytest.fixture(scope="module")
def hovering():
    return signature(1)


def test_hovering_signature_is_mirror_symmetric_by_nature(hovering):
    """The hovering target itself, measured as if it were receiver noise, reads like a
    badly unbalanced receiver although it is perfectly balanced: this is what the
    check must not do."""
    z, bg, _ = hovering
    m = mirror_balance(receiver(z))
    assert -20 * np.log10(m["r"]) < IMAGE_REJECTION_WARN_DB - 2, m
    assert -20 * np.log10(mirror_balance(receiver(bg))["r"]) > IMAGE_REJECTION_WARN_DB + 6


def test_hovering_balanced_without_background_is_not_measurable(capsys, tmp_path, hovering):
    z, _, _ = hovering
    imp, warns, err = run_import(capsys, tmp_path, receiver(z), "--range-m", "60")
    assert not warns, err
    assert imp["image_rejection_db"] is None and imp["image_rejection_note"].startswith("not measurable"), imp
    assert "mirror-symmetric" in imp["image_rejection_note"]
    assert "image rejection not measurable" in err


@pytest.mark.parametrize("gain_db, phase_deg", [(0, 0), (1, 0), (0, 5)])
def test_hovering_with_background_measures_the_receiver(capsys, tmp_path, hovering, gain_db, phase_deg):
    z, bg, _ = hovering
    imp, warns, err = run_import(
        capsys, tmp_path, receiver(z, gain_db, phase_deg), "--range-m", "60", bg=receiver(bg, gain_db, phase_deg)
    )
    assert imp["image_rejection_from"] == "background", imp
    if gain_db == phase_deg == 0:
        assert not warns and imp["image_rejection_db"] > IMAGE_REJECTION_WARN_DB, (imp, err)
        return
    assert len(warns) == 1 and "measured on the background recording" in warns[0], err
    assert abs(imp["image_rejection_db"] - irr_db(gain_db, phase_deg)) < 1.5, imp
    assert abs(imp["amplitude_imbalance_db"] - gain_db) < 0.3 and abs(imp["phase_imbalance_deg"] - phase_deg) < 1.0


def test_hovering_with_imbalance_and_a_target_free_stretch(capsys, tmp_path):
    """No background, but the recording's first 3 s hold no target (it is switched on
    later): ``--noise-segment-s 0:3`` measures the receiver there."""
    z, _, _ = signature(2, target_from_s=3.0)
    imp, warns, err = run_import(capsys, tmp_path, receiver(z, 1.0, 5.0), "--range-m", "60", "--noise-segment-s", "0:3")
    assert imp["image_rejection_from"] == "noise segment" and imp["noise_segment_s"] == [0.0, 3.0], imp
    assert len(warns) == 1 and "measured on the noise segment" in warns[0], err
    assert abs(imp["image_rejection_db"] - irr_db(1.0, 5.0)) < 1.5, imp
    # without the stretch named, the same recording is not measurable (and not warned about)
    imp, warns, err = run_import(capsys, tmp_path, receiver(z, 1.0, 5.0), "--range-m", "60", "--overwrite")
    assert imp["image_rejection_db"] is None and not warns, err


@pytest.mark.parametrize("gain_db, phase_deg", [(0, 0), (1, 0), (0, 5)])
def test_flying_target_measures_the_body_lines_image(capsys, tmp_path, gain_db, phase_deg):
    """Approaching at 6 m/s (body at +132 Hz, 27 bins of 1024 from 0 Hz): the body
    line's image is the receiver's, with or without a background."""
    z, _, t = signature(3, speed_mps=-6.0)
    pd.DataFrame({"time_s": t[::500], "range_m": 60.0 - 6.0 * t[::500]}).to_csv(tmp_path / "t.csv", index=False)
    imp, warns, err = run_import(capsys, tmp_path, receiver(z, gain_db, phase_deg), "--track", tmp_path / "t.csv")
    assert imp["image_rejection_from"] == "body line", imp
    assert imp["doppler_sign_db"] > 10, imp
    if gain_db == phase_deg == 0:
        assert not warns and imp["image_rejection_db"] > IMAGE_REJECTION_WARN_DB, (imp, err)
        return
    assert len(warns) == 1 and "measured on the body line's mirror image" in warns[0], err
    assert abs(imp["image_rejection_db"] - irr_db(gain_db, phase_deg)) < 1.5, imp


def test_flying_target_without_a_track_finds_its_body_line(capsys, tmp_path):
    """A constant-range import of a flying target: the body is the strongest line
    outside the notch with a much weaker mirror, so the balance is still measured."""
    z, _, _ = signature(4, speed_mps=5.0)
    imp, warns, err = run_import(capsys, tmp_path, receiver(z, 1.0, 0.0), "--range-m", "60")
    assert imp["image_rejection_from"] == "body line", imp
    assert len(warns) == 1 and "I/Q image rejection" in warns[0], err


def test_bad_noise_segment(capsys, tmp_path, hovering):
    z, _, _ = hovering
    np.save(tmp_path / "r.npy", receiver(z))
    for seg, must in (
        ("3:1", ("--noise-segment-s", "3:1", "START < END")),
        ("0:20", ("r.npy", "noise_segment_s", "beyond the recording's 8.000 s")),
    ):
        rc, err = run_cli(
            capsys,
            [
                "import",
                tmp_path / "r.npy",
                *OPTS,
                "--range-m",
                "60",
                "--noise-segment-s",
                seg,
                "--out",
                tmp_path / "o.zarr",
            ],
        )
        one_line(rc, err, *must)
        assert not (tmp_path / "o.zarr").exists()
