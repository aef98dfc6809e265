"""``microdoppler import``: recordings (SigMF, MATLAB v5/v7.3, NumPy) -> flight-zarr/1.

The fixtures are written here from an emulated drone flight: each format round-trips
(import -> validate -> the same I/Q, attributes and track); every bad input is one
line, exit status 2 and nothing written.
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.io
import sigmf
import yaml
from sigmf import SigMFFile

from conftest import one_line, run_cli
from microdoppler.emulator.world import FlightSpec, emulate_flight
from microdoppler.importing.iqbalance import iq_sanity
from microdoppler.io.flightzarr import read_flight
from microdoppler.io.inventory import list_flights
from microdoppler.io.recordings import read_recording

GEOMETRY = ("drone_model", "n_motors", "n_blades", "blade_length_m")
REQUIRED_ATTRS = ("schema", "flight_id", "target", "radar_id", "prf_hz", "carrier_hz", *GEOMETRY)
DRONE_OPTS = [
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
    "--radar-id",
    "radar1",
]


# ---- fixtures: an emulated flight and its recordings --------------------------------


@pytest.fixture(scope="module")
def flight():
    f, _ = emulate_flight(
        FlightSpec("rec1", "drone", drone_model="inspire2", duration_s=6.0, seed=3, with_background=False)
    )
    return f


def write_track(path, f, velocity=True):
    cols = {"time_s": f.track_time_s, "range_m": f.track_range_m}
    if velocity:
        cols["radial_velocity_mps"] = f.track_radial_velocity_mps
    import pandas as pd

    pd.DataFrame(cols).to_csv(path, index=False, float_format="%.17g")
    return path


def ci16_scale(iq):
    return 32000.0 / float(max(np.abs(iq.real).max(), np.abs(iq.imag).max()))


def write_sigmf(
    d,
    name,
    iq,
    *,
    datatype="cf32_le",
    sample_rate=7300.0,
    carrier_hz=1.35e9,
    label="drone",
    extra=None,
    annotate=True,
    checksum=True,
):
    """A SigMF pair written through the ``sigmf`` package."""
    data = Path(d) / f"{name}.sigmf-data"
    if datatype == "cf32_le":
        np.asarray(iq, np.complex64).tofile(data)
    elif datatype == "ci16_le":
        s = ci16_scale(iq)
        z = np.empty((len(iq), 2), "<i2")
        z[:, 0], z[:, 1] = np.round(iq.real * s), np.round(iq.imag * s)
        z.tofile(data)
    else:
        raise ValueError(datatype)
    info = {"core:datatype": datatype, "core:description": "test recording", "core:author": "tests"}
    if sample_rate is not None:
        info["core:sample_rate"] = sample_rate
    if extra:
        info["core:extensions"] = [{"name": "microdoppler", "version": "1.0.0", "optional": True}]
        info.update({f"microdoppler:{k}": v for k, v in extra.items()})
    meta = SigMFFile(data_file=data, global_info=info, skip_checksum=not checksum)
    meta.add_capture(0, metadata={"core:frequency": carrier_hz, "core:datetime": "2026-01-02T03:04:05Z"})
    if annotate:
        meta.add_annotation(0, len(iq), metadata={"core:label": label})
    path = Path(d) / f"{name}.sigmf-meta"
    meta.tofile(path)
    return path


def edit_meta(path, fn):
    meta = json.loads(Path(path).read_text())
    fn(meta)
    Path(path).write_text(json.dumps(meta))
    return path


def write_mat73(path, variables):
    """A MATLAB v7.3 file as MATLAB writes it: HDF5 with a 512-byte userblock whose
    header says MATLAB 7.3, arrays transposed (column-major), complex arrays as
    compound real/imag datasets, MATLAB_class attributes, char as uint16."""
    with h5py.File(path, "w", userblock_size=512) as h:
        for name, v in variables.items():
            if isinstance(v, str):
                ds = h.create_dataset(name, data=np.array([[ord(c)] for c in v], np.uint16))  # 1xL -> (L, 1)
                ds.attrs["MATLAB_class"] = np.bytes_("char")
                ds.attrs["MATLAB_int_decode"] = np.int32(2)
                continue
            a = np.atleast_2d(np.asarray(v))
            if a.ndim == 2 and a.shape[0] == 1 and np.ndim(v) == 1:
                a = a.T  # a MATLAB column vector n x 1
            cls = {
                np.dtype(np.float64): "double",
                np.dtype(np.float32): "single",
                np.dtype(np.complex128): "double",
                np.dtype(np.complex64): "single",
            }[a.dtype]
            if np.iscomplexobj(a):
                part = np.float64 if a.dtype == np.complex128 else np.float32
                c = np.empty(a.shape, np.dtype([("real", part), ("imag", part)]))
                c["real"], c["imag"] = a.real, a.imag
                a = c
            ds = h.create_dataset(name, data=a.T)  # HDF5 holds MATLAB's column-major array transposed
            ds.attrs["MATLAB_class"] = np.bytes_(cls)
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Fri Jan  2 03:04:05 2026 HDF5 schema 1.00 ."
    with open(path, "r+b") as fh:
        fh.write(header.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02" + b"IM")
    return path


def mat_variables(f):
    a = f.attrs
    return {
        "iq": f.iq,
        "prf_hz": a["prf_hz"],
        "carrier_hz": a["carrier_hz"],
        "radar_id": a["radar_id"],
        "target": a["target"],
        "drone_model": a["drone_model"],
        "n_motors": float(a["n_motors"]),
        "n_blades": float(a["n_blades"]),
        "blade_length_m": a["blade_length_m"],
        "track_time_s": f.track_time_s,
        "track_range_m": f.track_range_m,
        "track_radial_velocity_mps": f.track_radial_velocity_mps,
    }


def assert_round_trip(out, f, *, iq_atol=0.0, flight_id="rec1"):
    g = read_flight(out)  # validates
    for k in REQUIRED_ATTRS:
        want = flight_id if k == "flight_id" else f.attrs[k]
        assert g.attrs[k] == want, (k, g.attrs[k], want)
    if iq_atol == 0:
        np.testing.assert_array_equal(g.iq, f.iq)
    else:
        np.testing.assert_allclose(g.iq.real, f.iq.real, rtol=0, atol=iq_atol)
        np.testing.assert_allclose(g.iq.imag, f.iq.imag, rtol=0, atol=iq_atol)
    np.testing.assert_array_equal(g.track_time_s, f.track_time_s)
    np.testing.assert_array_equal(g.track_range_m, f.track_range_m)
    np.testing.assert_array_equal(g.track_radial_velocity_mps, f.track_radial_velocity_mps)
    return g


# ---- round trips -------------------------------------------------------------------


def test_sigmf_cf32_round_trip(capsys, tmp_path, flight):
    """Everything but the track in the SigMF metadata (core: and microdoppler: keys)."""
    a = flight.attrs
    meta = write_sigmf(tmp_path, "rec1", flight.iq, extra={k: a[k] for k in ("radar_id", *GEOMETRY)})
    track = write_track(tmp_path / "track.csv", flight)
    out = tmp_path / "rec1.zarr"
    rc, err = run_cli(capsys, ["import", meta, "--track", track, "--out", out])
    assert rc == 0, err
    assert "warning" not in err, err
    g = assert_round_trip(out, flight)
    imp = g.attrs["import"]
    assert imp["format"] == "sigmf" and imp["layout"] == "complex" and imp["datatype"] == "cf32_le"
    assert imp["source_file"] == str(meta) and imp["warnings"] == []
    assert imp["image_rejection_db"] > 25 and imp["doppler_sign_db"] > 0
    assert imp["parameter_sources"]["prf_hz"] == "file global.core:sample_rate"
    assert imp["parameter_sources"]["carrier_hz"] == "file captures[0].core:frequency"
    assert (
        imp["parameter_sources"]["target"] == "file global.microdoppler:target"
        or imp["parameter_sources"]["target"] == "file annotations.core:label"
    )
    assert imp["datetime"] == "2026-01-02T03:04:05Z" and imp["description"] == "test recording"
    assert g.attrs["written_by"] == "microdoppler"
    assert run_cli(capsys, ["validate", out])[0] == 0


def test_sigmf_ci16_round_trip_with_sidecar(capsys, tmp_path, flight):
    """Fixed point stays in ADC counts: equal to the original times the scale, within
    the int16 quantisation; the sidecar supplies what the file lacks."""
    meta = write_sigmf(tmp_path, "rec1", flight.iq, datatype="ci16_le")
    # named by the .sigmf-data file this time
    sidecar = tmp_path / "rec1.yaml"
    sidecar.write_text(
        yaml.safe_dump(
            {
                "radar_id": "radar1",
                "drone_model": "inspire2",
                "n_motors": 4,
                "n_blades": 2,
                "blade_length_m": 0.19,
                "track": "track.csv",
            }
        )
    )
    write_track(tmp_path / "track.csv", flight)
    out = tmp_path / "rec1.zarr"
    rc, err = run_cli(capsys, ["import", meta.with_suffix(".sigmf-data"), "--sidecar", sidecar, "--out", out])
    assert rc == 0, err
    s = ci16_scale(flight.iq)
    g = read_flight(out)
    scaled = type(flight)(
        attrs=flight.attrs,
        iq=(flight.iq * s).astype(np.complex64),
        track_time_s=flight.track_time_s,
        track_range_m=flight.track_range_m,
        track_radial_velocity_mps=flight.track_radial_velocity_mps,
    )
    assert_round_trip(out, scaled, iq_atol=0.5 + 1e-3 * 32000)  # rounding + float32 of the scaled original
    assert np.all(np.abs(g.iq.real) <= 32767) and np.array_equal(g.iq.real, np.round(g.iq.real))
    imp = g.attrs["import"]
    assert imp["datatype"] == "ci16_le" and imp["parameter_sources"]["radar_id"].startswith("sidecar ")
    assert imp["parameter_sources"]["target"] == "file annotations.core:label"


def test_mat_v5_round_trip_everything_in_the_file(capsys, tmp_path, flight):
    path = tmp_path / "rec1.mat"
    v = mat_variables(flight)
    v["iq"] = flight.iq[:, None]  # a MATLAB column vector
    scipy.io.savemat(path, v)
    out = tmp_path / "rec1.zarr"
    rc, err = run_cli(capsys, ["import", path, "--out", out])
    assert rc == 0, err
    g = assert_round_trip(out, flight)
    assert g.attrs["import"]["format"] == "mat-v5" and g.attrs["import"]["variable"] == "iq"
    assert g.attrs["import"]["track"] == "file arrays track_*"


def test_mat_v73_round_trip(capsys, tmp_path, flight):
    path = write_mat73(tmp_path / "rec1.mat", mat_variables(flight))
    assert path.read_bytes()[:10] == b"MATLAB 7.3" and h5py.is_hdf5(path)
    with pytest.raises(NotImplementedError):  # what scipy says about v7.3: the h5py reader is needed
        scipy.io.loadmat(path)
    out = tmp_path / "rec1.zarr"
    rc, err = run_cli(capsys, ["import", path, "--out", out])
    assert rc == 0, err
    g = assert_round_trip(out, flight)
    assert g.attrs["import"]["format"] == "mat-v7.3" and g.attrs["import"]["layout"] == "complex"


def test_npz_iq_columns_round_trip(capsys, tmp_path, flight):
    path = tmp_path / "rec1.npz"
    np.savez(path, I=flight.iq.real, Q=flight.iq.imag, prf_hz=7300.0, carrier_hz=1.35e9)
    out = tmp_path / "rec1.zarr"
    track = write_track(tmp_path / "t.csv", flight)
    rc, err = run_cli(capsys, ["import", path, *DRONE_OPTS, "--track", track, "--layout", "iq-columns", "--out", out])
    assert rc == 0, err
    g = assert_round_trip(out, flight)
    assert g.attrs["import"]["layout"] == "iq-columns" and g.attrs["import"]["variable"] == "I,Q"


def test_npy_two_columns_and_gradient_velocity(capsys, tmp_path, flight):
    path = tmp_path / "x.npy"
    np.save(path, np.stack([flight.iq.real, flight.iq.imag], axis=1))
    track = write_track(tmp_path / "t.csv", flight, velocity=False)
    out = tmp_path / "x.zarr"
    rc, err = run_cli(
        capsys,
        [
            "import",
            path,
            *DRONE_OPTS,
            "--prf-hz",
            "7300",
            "--carrier-hz",
            "1.35e9",
            "--track",
            track,
            "--flight-id",
            "rec1",
            "--out",
            out,
        ],
    )
    assert rc == 0, err
    g = read_flight(out)
    np.testing.assert_array_equal(g.iq, flight.iq)
    np.testing.assert_array_equal(g.track_range_m, flight.track_range_m)
    want = np.gradient(flight.track_range_m, flight.track_time_s)
    np.testing.assert_allclose(g.track_radial_velocity_mps, want)
    assert np.max(np.abs(want - flight.track_radial_velocity_mps)) < 0.3  # close to the tracker's own


def test_constant_range_staring_recording(capsys, tmp_path, flight):
    path = tmp_path / "stare.npy"
    np.save(path, flight.iq[:20000])
    out = tmp_path / "stare.zarr"
    rc, err = run_cli(
        capsys,
        [
            "import",
            path,
            "--prf-hz",
            "7300",
            "--carrier-hz",
            "1.35e9",
            "--radar-id",
            "r9",
            "--target",
            "bird",
            "--range-m",
            "850",
            "--out",
            out,
        ],
    )
    assert rc == 0, err
    g = read_flight(out)
    assert g.attrs["flight_id"] == "stare" and g.attrs["target"] == "bird" and "n_motors" not in g.attrs
    np.testing.assert_array_equal(g.track_time_s, [0.0, 20000 / 7300])
    np.testing.assert_array_equal(g.track_range_m, [850.0, 850.0])
    np.testing.assert_array_equal(g.track_radial_velocity_mps, [0.0, 0.0])
    assert g.attrs["import"]["doppler_sign_db"] is None  # no Doppler to check against


# ---- precedence ------------------------------------------------------------------


def test_option_beats_sidecar_beats_file_and_contradictions_warn(capsys, tmp_path, flight):
    meta = write_sigmf(tmp_path, "r", flight.iq[:30000], extra={"radar_id": "file-radar", "n_blades": 2})
    sidecar = tmp_path / "s.yaml"
    sidecar.write_text(
        "radar_id: side-radar\ndrone_model: side-model\nn_motors: 4\nblade_length_m: 0.19\nn_blades: 3\nrange_m: 700\n"
    )
    out = tmp_path / "r.zarr"
    rc, err = run_cli(
        capsys,
        [
            "import",
            meta,
            "--sidecar",
            sidecar,
            "--radar-id",
            "opt-radar",
            "--prf-hz",
            "7000",
            "--drone-model",
            "opt-model",
            "--out",
            out,
        ],
    )
    assert rc == 0, err
    a = read_flight(out).attrs
    assert (a["radar_id"], a["drone_model"], a["n_blades"], a["n_motors"]) == ("opt-radar", "opt-model", 3, 4)
    assert a["prf_hz"] == 7000.0
    warns = [ln for ln in err.splitlines() if ln.startswith("warning:")]
    assert any("--prf-hz = 7000.0 contradicts the file's global.core:sample_rate = 7300.0" in w for w in warns), err
    assert any("--radar-id" in w and "file-radar" in w for w in warns), err
    assert any("key n_blades = 3 contradicts" in w for w in warns), err
    assert not any("drone_model" in w for w in warns)  # the file says nothing about it: no contradiction
    src = a["import"]["parameter_sources"]
    assert src["radar_id"] == "--radar-id" and src["n_blades"].startswith("sidecar ")
    assert src["carrier_hz"] == "file captures[0].core:frequency"
    assert len(a["import"]["warnings"]) == len(warns)
    assert a["import"]["track"].startswith("constant range sidecar")


# ---- I/Q sanity -------------------------------------------------------------------


@pytest.mark.parametrize("case", ["Q = 0", "I = Q"])
def test_real_valued_signal_warns_with_image_rejection(capsys, tmp_path, flight, case):
    x = flight.iq.real.astype(np.float64)
    iq = (x + 0j) if case == "Q = 0" else (x + 1j * x)
    path = tmp_path / "real.npy"
    np.save(path, iq.astype(np.complex64))
    out = tmp_path / "real.zarr"
    rc, err = run_cli(
        capsys,
        ["import", path, *DRONE_OPTS, "--prf-hz", "7300", "--carrier-hz", "1.35e9", "--range-m", "900", "--out", out],
    )
    assert rc == 0, err
    warns = [ln for ln in err.splitlines() if ln.startswith("warning:")]
    assert len(warns) == 1 and "image rejection is 0.0 dB" in warns[0] and "real-valued" in warns[0], err
    imp = read_flight(out).attrs["import"]
    assert imp["image_rejection_db"] == 0.0 and imp["warnings"] == [warns[0].split(": ", 2)[2]]


def test_swapped_i_and_q_warn_against_the_track(capsys, tmp_path, flight):
    path = tmp_path / "swapped.npz"
    np.savez(path, I=flight.iq.imag, Q=flight.iq.real)
    out = tmp_path / "swapped.zarr"
    track = write_track(tmp_path / "t.csv", flight)
    rc, err = run_cli(
        capsys,
        ["import", path, *DRONE_OPTS, "--prf-hz", "7300", "--carrier-hz", "1.35e9", "--track", track, "--out", out],
    )
    assert rc == 0, err
    assert "I and Q look swapped" in err and "image rejection is" not in err, err
    imp = read_flight(out).attrs["import"]
    assert imp["doppler_sign_db"] < -3 and imp["image_rejection_db"] > 25


def test_image_rejection_measures_a_known_imbalance():
    """A receiver with 1.1 gain and 3 deg phase error on Q: IRR 25.3 dB (white noise in,
    the whole recording declared target-free; or given as the background)."""
    rng = np.random.default_rng(5)
    z = rng.standard_normal(1 << 18) + 1j * rng.standard_normal(1 << 18)
    g, ph = 1.1, np.radians(3.0)
    bad = z.real + 1j * g * (z.imag * np.cos(ph) + z.real * np.sin(ph))
    want = 10 * np.log10((1 + 2 * g * np.cos(ph) + g * g) / (1 - 2 * g * np.cos(ph) + g * g))
    whole = (0.0, len(z) / 7300.0)
    for s in (iq_sanity(bad, 7300.0, noise_s=whole), iq_sanity(bad[:50000], 7300.0, background=bad)):
        assert abs(s["image_rejection_db"] - want) < 1.0, (s, want)
        assert abs(s["amplitude_imbalance_db"] + 20 * np.log10(g)) < 0.1 and abs(s["phase_imbalance_deg"] - 3) < 0.3, s
    assert iq_sanity(z, 7300.0, noise_s=whole)["image_rejection_db"] > 40
    assert iq_sanity(z.real, 7300.0)["image_rejection_db"] == 0.0  # real-valued samples: whatever the target
    s = iq_sanity(bad, 7300.0)  # noise with no target, background or noise segment: nothing to measure on
    assert s["image_rejection_db"] is None and s["image_rejection_note"].startswith("not measurable"), s


# ---- batch ----------------------------------------------------------------------------


def test_batch_converts_a_campaign_for_the_pipeline(capsys, tmp_path, flight):
    rec = tmp_path / "recordings"
    rec.mkdir()
    a = flight.attrs
    write_sigmf(rec, "f001", flight.iq, extra={k: a[k] for k in GEOMETRY})
    write_track(rec / "f001.csv", flight)
    np.savez(rec / "b.npz", iq=flight.iq[:20000], prf_hz=7300.0, carrier_hz=1.35e9)
    table = tmp_path / "campaign.csv"
    table.write_text(
        "file,radar_id,track,flight_id,target,range_m\n"
        "recordings/f001.sigmf-meta,radar1,recordings/f001.csv,,,\n"
        "recordings/b.npz,radar2,,bird007,bird,1200\n"
    )
    out = tmp_path / "measured"
    rc, err = run_cli(capsys, ["import", "--batch", table, "--out", out])
    assert rc == 0, err
    assert sorted(p.name for p in out.iterdir()) == ["bird007.zarr", "f001.zarr"]
    assert_round_trip(out / "f001.zarr", flight, flight_id="f001")
    df = list_flights(out)  # what measurements.source: directory reads
    assert list(df.flight_id) == ["bird007", "f001"] and list(df.radar_id) == ["radar2", "radar1"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    # a second run needs --overwrite, and then replaces the folder's own stores
    rc, err = run_cli(capsys, ["import", "--batch", table, "--out", out])
    one_line(rc, err, "--overwrite")
    rc, err = run_cli(capsys, ["import", "--batch", table, "--out", out, "--overwrite", "--quiet"])
    assert rc == 0 and err == "", err


# ---- bad input: one line, exit 2, nothing written ----------------------------------


def _iq(n=4096):
    rng = np.random.default_rng(1)
    return (rng.standard_normal(n) + 1j * rng.standard_normal(n)).astype(np.complex64)


OK = ["--radar-id", "r1", "--target", "bird", "--range-m", "500"]
FULL = [*OK, "--prf-hz", "7300", "--carrier-hz", "1.35e9"]


def _truncate(path, n_bytes):
    data = Path(path).read_bytes()
    Path(path).write_bytes(data[: len(data) - n_bytes])


def case_sigmf_partial_sample(d):
    m = write_sigmf(d, "r", _iq(), datatype="ci16_le", checksum=False)
    _truncate(m.with_suffix(".sigmf-data"), 3)
    return [m, *OK], ("r.sigmf-data", "size", "truncated")


def case_sigmf_fewer_than_annotated(d):
    m = write_sigmf(d, "r", _iq(), checksum=False)
    _truncate(m.with_suffix(".sigmf-data"), 8 * 100)
    return [m, *OK], ("annotations[0]", "4096", "3996 samples")


def case_sigmf_capture_beyond_end(d):
    m = write_sigmf(d, "r", _iq(), annotate=False, checksum=False)
    edit_meta(m, lambda x: x["captures"].append({"core:sample_start": 5000, "core:frequency": 1.35e9}))
    return [m, *OK], ("captures[1].core:sample_start", "5000")


def case_sigmf_checksum(d):
    m = write_sigmf(d, "r", _iq())
    data = m.with_suffix(".sigmf-data")
    b = bytearray(data.read_bytes())
    b[100] ^= 0xFF
    data.write_bytes(bytes(b))
    return [m, *OK], ("core:sha512",)


def case_sigmf_n_samples(d):
    m = write_sigmf(d, "r", _iq(), extra={"n_samples": 5000})
    return [m, *OK], ("n_samples", "4096", "5000")


def case_npz_n_samples(d):
    np.savez(d / "r.npz", iq=_iq(), n_samples=4000)
    return [d / "r.npz", *FULL], ("r.npz", "n_samples", "4096")


def case_sigmf_unknown_datatype(d):
    m = edit_meta(write_sigmf(d, "r", _iq()), lambda x: x["global"].update({"core:datatype": "cq16_le"}))
    return [m, *OK], ("core:datatype", "cq16_le", "cf32_le")


def case_sigmf_real_datatype(d):
    m = edit_meta(
        write_sigmf(d, "r", _iq(), checksum=False), lambda x: x["global"].update({"core:datatype": "rf32_le"})
    )
    return [m, *OK], ("core:datatype", "real")


def case_sigmf_missing_sample_rate(d):
    m = write_sigmf(d, "r", _iq(), sample_rate=None)
    return [m, *OK], ("prf_hz", "core:sample_rate", "--prf-hz")


def case_sigmf_missing_data(d):
    m = write_sigmf(d, "r", _iq())
    m.with_suffix(".sigmf-data").unlink()
    return [m, *OK], ("r.sigmf-meta", "data")


def case_sigmf_meta_not_json(d):
    m = write_sigmf(d, "r", _iq())
    m.write_text('{"global": {')
    return [m, *OK], ("r.sigmf-meta", "JSON")


def case_mat_unreadable(d):
    (d / "r.mat").write_bytes(b"this is not a mat file at all" * 10)
    return [d / "r.mat", *FULL], ("r.mat", "file", "MATLAB")


def case_mat73_truncated(d):
    p = write_mat73(d / "r.mat", {"iq": _iq(), "prf_hz": 7300.0})
    _truncate(p, p.stat().st_size // 2)
    return [p, *FULL], ("r.mat",)


def case_mat_wrong_shape(d):
    scipy.io.savemat(d / "r.mat", {"iq": np.ones((100, 3))})
    return [d / "r.mat", *FULL], ("r.mat", "iq", "(100, 3)", "[n, 2]")


def case_npy_complex_matrix(d):
    np.save(d / "r.npy", _iq(4000).reshape(1000, 4))
    return [d / "r.npy", *FULL], ("r.npy", "(1000, 4)", "complex vector")


def case_npy_real_vector(d):
    np.save(d / "r.npy", _iq().real)
    return [d / "r.npy", *FULL], ("r.npy", "real-valued", "I, Q")


def case_npz_nan(d):
    x = _iq()
    x[123] = np.nan
    np.savez(d / "r.npz", I=x.real, Q=x.imag)
    return [d / "r.npz", *FULL], ("r.npz", "NaN", "sample 123")


def case_sigmf_nan(d):
    x = _iq()
    x[7] = np.inf
    return [write_sigmf(d, "r", x), *OK], ("r.sigmf-data", "NaN", "sample 7")


def case_several_arrays(d):
    np.savez(d / "r.npz", a=_iq(), b=_iq())
    return [d / "r.npz", *FULL], ("r.npz", "a, b", "--variable")


def case_unknown_variable(d):
    np.savez(d / "r.npz", a=_iq(), b=_iq())
    return [d / "r.npz", *FULL, "--variable", "c"], ("r.npz", "c", "a, b")


def case_layout_contradicts(d):
    np.save(d / "r.npy", _iq())
    return [d / "r.npy", *FULL, "--layout", "iq-columns"], ("r.npy", "--layout complex")


def case_sigmf_layout_contradicts(d):
    return [write_sigmf(d, "r", _iq()), *OK, "--layout", "iq-columns"], ("core:datatype", "--layout complex")


def case_missing_radar_id(d):
    return [write_sigmf(d, "r", _iq()), "--range-m", "500"], ("radar_id", "--radar-id")


def case_missing_drone_geometry(d):
    return [
        write_sigmf(d, "r", _iq()),
        "--radar-id",
        "r1",
        "--range-m",
        "500",
        "--drone-model",
        "x",
        "--n-motors",
        "4",
        "--blade-length-m",
        "0.2",
    ], ("n_blades", "--n-blades")


def case_missing_track(d):
    return [write_sigmf(d, "r", _iq()), "--radar-id", "r1", "--target", "bird"], ("track", "--range-m")


def case_bad_track_csv(d):
    (d / "t.csv").write_text("time_s,range_m\n0,100\n0,101\n")
    return [write_sigmf(d, "r", _iq()), "--radar-id", "r1", "--target", "bird", "--track", d / "t.csv"], (
        "t.csv",
        "time_s",
    )


def case_bad_sidecar_key(d):
    (d / "s.yaml").write_text("prf: 7300\n")
    return [write_sigmf(d, "r", _iq()), *OK, "--sidecar", d / "s.yaml"], ("s.yaml", "prf", "prf_hz")


def case_bad_sidecar_value(d):
    (d / "s.yaml").write_text("n_motors: 2.5\n")
    return [write_sigmf(d, "r", _iq()), *OK, "--sidecar", d / "s.yaml"], ("s.yaml", "n_motors", "integer")


def case_bad_target_in_file(d):
    np.savez(d / "r.npz", iq=_iq(), target="plane")
    return [d / "r.npz", "--prf-hz", "7300", "--carrier-hz", "1e9", "--radar-id", "x", "--range-m", "5"], (
        "r.npz",
        "target",
        "plane",
        "drone or bird or none",
    )


def case_unknown_suffix(d):
    (d / "r.wav").write_bytes(b"RIFF")
    return [d / "r.wav", *FULL], ("r.wav", "suffix")


def case_bad_prf_option(d):
    return [write_sigmf(d, "r", _iq()), *OK, "--prf-hz", "nan"], ("--prf-hz",)


def case_out_exists(d):
    (d / "out.zarr").mkdir()
    (d / "out.zarr" / "notes.txt").write_text("mine")
    return [write_sigmf(d, "r", _iq()), *OK], ("out.zarr", "already exists")


def case_batch_missing_file_column(d):
    (d / "t.csv").write_text("path,radar_id\nr.npy,x\n")
    return ["--batch", d / "t.csv"], ("t.csv", "file", "column missing")


def case_batch_unknown_column(d):
    (d / "t.csv").write_text("file,prf\nr.npy,7300\n")
    return ["--batch", d / "t.csv"], ("t.csv", "prf", "prf_hz")


def case_batch_duplicate_flight_id(d):
    np.save(d / "a.npy", _iq())
    np.save(d / "b.npy", _iq())
    (d / "t.csv").write_text("file,flight_id\na.npy,same\nb.npy,same\n")
    return ["--batch", d / "t.csv", *FULL], ("t.csv row 3", "flight_id", "'same'")


def case_batch_bad_row(d):
    np.save(d / "a.npy", _iq())
    (d / "t.csv").write_text("file,n_blades\na.npy,\nmissing.npy,\n")
    return ["--batch", d / "t.csv", *FULL], ("missing.npy", "does not exist")


def case_batch_bad_cell(d):
    (d / "t.csv").write_text("file,prf_hz\na.npy,fast\n")
    return ["--batch", d / "t.csv"], ("t.csv row 2", "prf_hz", "'fast'")


def case_batch_and_recording(d):
    np.save(d / "a.npy", _iq())
    (d / "t.csv").write_text("file\na.npy\n")
    return [d / "a.npy", "--batch", d / "t.csv", *FULL], ("--batch",)


CASES = {name[5:]: fn for name, fn in globals().items() if name.startswith("case_")}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_input_one_line_nothing_written(capsys, tmp_path, case):
    d = tmp_path / "in"
    d.mkdir()
    argv, must = CASES[case](d)
    out = d / "out.zarr" if case == "out_exists" else tmp_path / ("out" if "batch" in case else "out.zarr")
    before = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")}
    rc, err = run_cli(capsys, ["import", *argv, "--out", out])
    one_line(rc, err, *must)
    if case == "out_exists":
        assert (out / "notes.txt").read_text() == "mine"
    else:
        assert not out.exists()
    after = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*")}
    assert after == before  # nothing written, nothing touched, no temporaries


def test_library_reader_returns_complex64_and_metadata(tmp_path, flight):
    m = write_sigmf(tmp_path, "r", flight.iq[:5000], extra={"radar_id": "radar1"})
    rec = read_recording(m)
    assert rec.iq.dtype == np.complex64 and len(rec.iq) == 5000
    assert rec.metadata == {"radar_id": "radar1", "prf_hz": 7300.0, "carrier_hz": 1.35e9, "target": "drone"}
    assert rec.fields["prf_hz"] == "global.core:sample_rate"
    assert sigmf.__version__  # the package the pair was written (and is read) with


# ---- round trip to a diagnosis ------------------------------------------------------


def _strip_timing(obj):
    if isinstance(obj, dict):
        return {k: _strip_timing(v) for k, v in obj.items() if k != "seconds"}
    if isinstance(obj, list):
        return [_strip_timing(v) for v in obj]
    return obj


def test_round_trip_import_validate_diagnose_gives_the_original_report(tmp_path, capsys):
    """A flight exported to SigMF (+ its track and motor-log CSVs), imported, validated
    and diagnosed gives the same report as diagnosing the original store."""
    from microdoppler.diagnosis import diagnose
    from microdoppler.io.flightzarr import write_flight

    f, _ = emulate_flight(
        FlightSpec(
            "rt1",
            "drone",
            drone_model="inspire2",
            duration_s=24.0,
            snr_db=42.0,
            mean_range_m=1200.0,
            seed=17,
            effects={"sideband_asymmetry": {"asymmetry_db": 4.5}},
        )
    )
    original = write_flight(tmp_path / "orig" / "rt1.zarr", f)
    rec = tmp_path / "rec"
    rec.mkdir()
    write_sigmf(rec, "rt1", f.iq, sample_rate=f.prf_hz, carrier_hz=f.carrier_hz)
    write_sigmf(rec, "rt1_bg", f.background_iq, sample_rate=f.prf_hz, carrier_hz=f.carrier_hz, label="none")
    track = write_track(rec / "track.csv", f)
    import pandas as pd

    log = pd.DataFrame(
        {"time_s": f.motors_time_s, **{f"m{k + 1}": f.motors_rpm[:, k] for k in range(f.motors_rpm.shape[1])}}
    )
    log.to_csv(rec / "log.csv", index=False, float_format="%.17g")
    out = tmp_path / "imp" / "rt1.zarr"
    rc, err = run_cli(
        capsys,
        [
            "import",
            rec / "rt1.sigmf-meta",
            *DRONE_OPTS,
            "--radar-id",
            f.attrs["radar_id"],
            "--track",
            track,
            "--motor-log",
            rec / "log.csv",
            "--flight-id",
            "rt1",
            "--background",
            rec / "rt1_bg.sigmf-meta",
            "--out",
            out,
            "--quiet",
        ],
    )
    assert rc == 0, err
    assert run_cli(capsys, ["validate", out])[0] == 0
    imported = read_flight(out)
    np.testing.assert_array_equal(imported.motors_rpm, f.motors_rpm)
    assert imported.attrs["motors_source"] == "log"
    np.testing.assert_array_equal(imported.background_iq, f.background_iq)
    a = diagnose([original], tmp_path / "a.json", config={"figures": False}, log=lambda m: None)
    b = diagnose([out], tmp_path / "b.json", config={"figures": False}, log=lambda m: None)
    assert _strip_timing(a["flights"]) == _strip_timing(b["flights"])
    assert a["flights"][0]["cause"] not in ("skipped",)


@pytest.mark.parametrize(
    "case, field",
    [("log with 3 motors", "motor columns"), ("short background", "samples"), ("log in rev/s declared rpm", "rpm")],
)
def test_motor_log_and_background_bad_input(tmp_path, capsys, flight, case, field):
    rec = write_sigmf(tmp_path, "r", flight.iq, sample_rate=flight.prf_hz, carrier_hz=flight.carrier_hz)
    t = np.arange(0, 6, 1 / 30)
    rpm = 3 if case == "log with 3 motors" else 4
    scale = 1 / 60 if case == "log in rev/s declared rpm" else 1
    import pandas as pd

    pd.DataFrame({"time_s": t, **{f"m{k}": np.full(len(t), 5000.0 * scale) for k in range(rpm)}}).to_csv(
        tmp_path / "log.csv", index=False
    )
    extra = ["--motor-log", tmp_path / "log.csv"]
    if case == "short background":
        extra = [
            "--background",
            write_sigmf(
                tmp_path, "bg", flight.iq[:-10], sample_rate=flight.prf_hz, carrier_hz=flight.carrier_hz, label="none"
            ),
        ]
    out = tmp_path / "o.zarr"
    rc, err = run_cli(capsys, ["import", rec, *DRONE_OPTS, "--range-m", "900", *extra, "--out", out])
    one_line(rc, err, field)
    assert not out.exists()


@pytest.mark.slow
def test_imported_campaign_gives_calibrated_twins_through_the_pipeline(tmp_path, capsys):
    """A campaign of SigMF recordings (two Inspire flights, one with its motor-log CSV,
    one without; their background recordings and tracks; a bird) imported with
    ``--batch`` runs through the pipeline's ingest and twin rules with
    ``measurements.source: directory``: the drone without a log gets rotor speeds from
    the radar, and both twins are calibrated within the tolerance."""
    import shutil
    import subprocess
    import sys

    import pandas as pd

    repo = Path(__file__).resolve().parents[1]
    rec = tmp_path / "recordings"
    rec.mkdir()
    specs = [
        FlightSpec(
            "c1",
            "drone",
            drone_model="inspire2",
            duration_s=8.0,
            snr_db=44.0,
            mean_range_m=1000.0,
            seed=21,
            radar_id="radar1",
        ),
        FlightSpec(
            "c2",
            "drone",
            drone_model="inspire2",
            duration_s=8.0,
            snr_db=44.0,
            mean_range_m=1300.0,
            seed=22,
            radar_id="radar2",
        ),
        FlightSpec("c3", "bird", bird_kind="single", duration_s=8.0, seed=23, radar_id="radar1"),
    ]
    rows = []
    for spec in specs:
        f, _ = emulate_flight(spec)
        fid = spec.flight_id
        write_sigmf(rec, fid, f.iq, sample_rate=f.prf_hz, carrier_hz=f.carrier_hz, label=spec.target)
        write_sigmf(rec, f"{fid}_bg", f.background_iq, sample_rate=f.prf_hz, carrier_hz=f.carrier_hz, label="none")
        write_track(rec / f"{fid}.csv", f)
        row = {
            "file": f"recordings/{fid}.sigmf-meta",
            "background": f"recordings/{fid}_bg.sigmf-meta",
            "track": f"recordings/{fid}.csv",
            "flight_id": fid,
            "target": spec.target,
            "radar_id": spec.radar_id,
            "motor_log": "",
        }
        if spec.target == "drone":
            row.update({k: f.attrs[k] for k in GEOMETRY})
        if fid == "c1":
            pd.DataFrame(
                {"time_s": f.motors_time_s, **{f"m{k + 1}": f.motors_rpm[:, k] for k in range(f.motors_rpm.shape[1])}}
            ).to_csv(rec / "c1_log.csv", index=False, float_format="%.17g")
            row["motor_log"] = "recordings/c1_log.csv"
        rows.append(row)
    table = tmp_path / "campaign.csv"
    pd.DataFrame(rows).to_csv(table, index=False)
    wd = tmp_path / "wd"
    rc, err = run_cli(capsys, ["import", "--batch", table, "--out", wd / "results" / "measured", "--quiet"])
    assert rc == 0, err
    assert read_flight(wd / "results/measured/c1.zarr").attrs["motors_source"] == "log"
    assert read_flight(wd / "results/measured/c2.zarr").motors_rpm is None
    cfg = yaml.safe_load((repo / "config/config.yaml").read_text())
    cfg["measurements"].update(source="directory", directory="results/measured", estimate_missing_motor_logs=True)
    (wd / "config.yaml").write_text(yaml.safe_dump(cfg))
    exe = shutil.which("snakemake") or str(Path(sys.executable).with_name("snakemake"))
    r = subprocess.run(
        [
            exe,
            "results/reports/table_iv_sub_cpi.csv",
            "--cores",
            "2",
            "-s",
            str(repo / "Snakefile"),
            "-d",
            str(wd),
            "--configfile",
            "config.yaml",
            "-q",
            "progress",
        ],
        cwd=wd,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    ingest = pd.read_csv(wd / "results/motors/ingest.csv").set_index("flight_id")
    assert ingest.loc["c1", "status"] == "ingested" and ingest.loc["c2", "status"] == "estimated"
    assert ingest.loc["c2", "source"] == "radar"
    t4 = pd.read_csv(wd / "results/reports/table_iv_sub_cpi.csv").set_index("flight_id")
    assert sorted(t4.index) == ["c1", "c2"]
    assert (t4.status == "ok").all(), t4.T
    tol = cfg["datasets"]["calibration"]["tolerance_db"]
    assert (t4.body_error_db.abs() <= tol).all() and (t4.sideband1_error_db.abs() <= tol).all()
    assert t4.loc["c2", "n_pairs_twin"] == pytest.approx(t4.loc["c2", "n_pairs_measured"], abs=1)


@pytest.mark.parametrize(
    "cell, extra, expect",
    [
        ({"motor_log_unit": "rps"}, [], ("row 2", "motor_log_unit", "'rps'", "rev/s")),
        ({"motor_log": "nolog.csv"}, [], ("nolog.csv", "does not exist")),
        ({"background": "short.npy"}, [], ("short.npy", "samples", "4096")),
        ({}, ["--background", "x.npy"], ("--background", "given with --batch", "background column")),
        ({}, ["--motor-log", "x.csv"], ("--motor-log", "given with --batch", "motor_log column")),
    ],
)
def test_batch_background_and_motor_log_columns_bad_input(capsys, tmp_path, cell, extra, expect):
    np.save(tmp_path / "r.npy", _iq())
    np.save(tmp_path / "short.npy", _iq(100))
    row = {
        "file": "r.npy",
        "prf_hz": 7300,
        "carrier_hz": 1.35e9,
        "radar_id": "r1",
        "target": "bird",
        "range_m": 500,
        **cell,
    }
    import pandas as pd

    pd.DataFrame([row]).to_csv(tmp_path / "t.csv", index=False)
    out = tmp_path / "out"
    rc, err = run_cli(capsys, ["import", "--batch", tmp_path / "t.csv", "--out", out, *extra])
    one_line(rc, err, *expect)
    assert not out.exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
