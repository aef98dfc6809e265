"""Direct twin fidelity (Table VI): features against known signals, distances, the
table's intervals, and the held-out fold of the calibration."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.signal.windows import blackmanharris

from microdoppler.datasets import fidelity
from microdoppler.datasets import calibration
from microdoppler.datasets.lines import log_rate_at
from microdoppler.diagnosis.hypotheses import folds
from microdoppler.io.motorlog import MotorLog
from microdoppler.spectra.spectrogram import SpectrogramConfig, spectrogram

from test_datasets_world import make_flight
from test_workflow_runs import new_workdir

PRF_HZ = 4096.0  # 1 Hz Doppler bins: every tone below sits on a bin centre
SPEC = SpectrogramConfig()
BODY_HZ, REV_S, N_BLADES = 60.0, 50.0, 2  # HERM line spacing B f_rot = 100 Hz


def ou_db(n: int, dt_s: float, tau_s: float, std_db: float, rng) -> np.ndarray:
    """Ornstein-Uhlenbeck process [dB], stationary from the first sample."""
    a = np.exp(-dt_s / tau_s)
    e = rng.standard_normal(n) * std_db * np.sqrt(1 - a * a)
    x = np.empty(n)
    x[0] = rng.standard_normal() * std_db
    for i in range(1, n):
        x[i] = a * x[i - 1] + e[i]
    return x


def tones(duration_s, rng, *, asym_db=6.0, fade_db=None, n_noise=0.2):
    """Body at 60 Hz, first pair at 160 / -40 Hz (upper ``asym_db`` above the lower),
    second lower sideband at -140 Hz (its upper side, 260 Hz, lies outside the 480
    central bins), white noise; the sidebands fade by ``fade_db`` [n_pulses] if given."""
    n = int(duration_s * PRF_HZ)
    t = np.arange(n) / PRF_HZ
    body = np.exp(2j * np.pi * BODY_HZ * t)
    side = (
        np.exp(2j * np.pi * (BODY_HZ + 100) * t)
        + 10 ** (-asym_db / 20) * np.exp(2j * np.pi * (BODY_HZ - 100) * t)
        + 0.5 * np.exp(2j * np.pi * (BODY_HZ - 200) * t)
    )
    if fade_db is not None:
        side = side * 10 ** (fade_db / 20)
    noise = n_noise * (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / np.sqrt(2)
    return (body + side + noise).astype(np.complex64)


def features(iq, cfg=fidelity.FidelityConfig(), spec_cfg=SPEC, log_rev_s=REV_S, body_hz=BODY_HZ):
    """Features of ``iq`` with four motors logged at ``log_rev_s`` and wire-neutral
    line powers (every rotation harmonic of one blade equally strong)."""
    spec = spectrogram(iq, PRF_HZ, spec_cfg)
    n_t = len(spec.time_s)
    return fidelity.cpi_features(
        spec,
        np.full(n_t, body_hz),
        np.full(n_t, log_rev_s),
        n_blades=N_BLADES,
        highpass_hz=spec_cfg.highpass_hz,
        cfg=cfg,
        motor_rev_s=np.full((n_t, 4), log_rev_s),
        line_power=np.ones(cfg.rotation_orders + 1),
        window=blackmanharris(spec_cfg.n_fft, sym=False),
    )


def test_features_of_known_lines(rng):
    f = features(tones(20.0, rng), fidelity.FidelityConfig(n_harmonics=3))
    # line frequencies: k B f_rot, to a fraction of the 1 Hz bin
    assert np.nanmax(np.abs(f.line_hz[0] - 100.0)) < 0.1
    assert np.nanmax(np.abs(f.line_hz[1] - 200.0)) < 0.1
    assert np.all(np.isnan(f.line_hz[2]))  # both third sidebands outside the 480 bins
    assert np.all(f.n_pairs == 2)
    assert np.allclose(f.asymmetry_db, 6.0, atol=0.3)
    assert np.allclose(f.first_pair_db, 0.0, atol=0.3)  # upper sideband as strong as the body
    # no fading: blade and body SNR constant to the noise's effect on a ~30 dB peak
    s = fidelity.summarise(f, np.ones(len(f.time_s), bool))
    # no fading: what is left is the SNR measure's own scatter (peak noise and the
    # median floor of 480 bins), well below a fading of dB
    assert s["blade_std_db"] < 0.6 and s["body_std_db"] < 0.6
    assert s["n_pairs"] == 2.0 and abs(s["asymmetry_db"] - 6.0) < 0.3


def rotation_lines(duration_s, rng, *, odd_rel, n_noise=0.05, body_hz=BODY_HZ):
    """Body at ``body_hz`` (60 Hz) and rotation harmonics k = 1..8 of REV_S = 50 rev/s on
    both sides: the blade-passing (even) lines fall off as exp(-0.15 k) in amplitude, the
    odd lines stand ``odd_rel`` (amplitude) times the geometric mean of the even lines
    beside them (k = 1: times its upper neighbour's), so their power ratio is odd_rel^2."""
    n = int(duration_s * PRF_HZ)
    t = np.arange(n) / PRF_HZ
    x = np.exp(2j * np.pi * body_hz * t)
    for k in range(1, 9):
        amp = np.exp(-0.15 * k) * (odd_rel if k % 2 else 1.0)
        for sgn in (1, -1):
            x = x + amp * np.exp(2j * np.pi * (body_hz + sgn * k * REV_S) * t + 1j * rng.uniform(0, 2 * np.pi))
    x = x + n_noise * (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / np.sqrt(2)
    return x.astype(np.complex64)


@pytest.mark.parametrize("odd_rel,log_scale", [(0.3, 1.0), (0.1, 1.0), (0.3, 1.08), (0.0, 0.93)])
def test_nonmultiple_lines_level(rng, odd_rel, log_scale):
    """nonmultiple_db reads the odd lines' power relative to the even lines beside
    them, 20 log10 odd_rel, also when the log's rates are off by a scale (the line
    dilation finds the lines); without odd lines it sits at the floor."""
    full = SpectrogramConfig(n_bins=0)
    cfg = fidelity.FidelityConfig()
    f = features(rotation_lines(12.0, rng, odd_rel=odd_rel), cfg, spec_cfg=full, log_rev_s=REV_S / log_scale)
    got = fidelity.nonmultiple_db(f, np.ones(len(f.time_s), bool), cfg)
    if odd_rel == 0:
        assert got == cfg.nonmultiple_floor_db
    else:
        assert abs(got - 20 * np.log10(odd_rel)) < 0.5, got
    assert (f.nonmultiple_ref > 0).mean() > 0.9  # the reference lines are seen in (nearly) every CPI
    few = np.zeros(len(f.time_s), bool)
    few[: cfg.nonmultiple_min_cpis - 1] = True  # too few CPIs: not measured
    assert np.isnan(fidelity.nonmultiple_db(f, few, cfg))
    # no per-motor rates: not measured
    spec = spectrogram(rotation_lines(3.0, rng, odd_rel=odd_rel), PRF_HZ, full)
    n_t = len(spec.time_s)
    g = fidelity.cpi_features(spec, np.full(n_t, BODY_HZ), np.full(n_t, REV_S), n_blades=N_BLADES, cfg=cfg)
    assert g.nonmultiple_pow is None and np.isnan(fidelity.nonmultiple_db(g, np.ones(n_t, bool), cfg))


@pytest.mark.parametrize("odd_rel", [0.3, 0.0])
def test_nonmultiple_lines_of_a_body_in_the_clutter_notch(rng, odd_rel):
    """A hovering or stand-mounted drone: the body at 0 Hz is high-passed away, its
    rotor lines stand about it. nonmultiple_db is read about the known body Doppler
    (the body line's own peak is not there to refer to): 20 log10 odd_rel, the floor
    without odd lines. Measured about the peak (the flying path), no CPI qualifies."""
    full = SpectrogramConfig(n_bins=0)
    cfg = fidelity.FidelityConfig()
    iq = rotation_lines(12.0, rng, odd_rel=odd_rel, body_hz=0.0)
    f = features(iq, cfg, spec_cfg=full, body_hz=0.0)
    got = fidelity.nonmultiple_db(f, np.ones(len(f.time_s), bool), cfg)
    if odd_rel == 0:
        assert got == cfg.nonmultiple_floor_db
    else:
        assert abs(got - 20 * np.log10(odd_rel)) < 0.5, got
    assert (f.nonmultiple_ref > 0).mean() > 0.9
    # the HERM lines are placed about 0 Hz too: k B f_rot from the body Doppler
    assert np.nanmedian(np.abs(f.line_hz[0] - N_BLADES * REV_S)) < 0.5
    # the features read on the (filtered-away) body line are not measured
    assert f.body_in_notch and np.isnan(f.body_db).all() and np.isnan(f.first_pair_db).all()
    assert np.isfinite(f.blade_db).all()
    # the flying path on the same spectrogram measures nothing
    spec = spectrogram(iq, PRF_HZ, full)
    n_t = len(spec.time_s)
    st = fidelity.Stft(
        10.0 ** (spec.power_db.astype(np.float64) / 10),
        spec.time_s,
        spec.doppler_hz,
        blackmanharris(full.n_fft, sym=False),
    )
    f_peak = fidelity.refine_peak(st, np.zeros(n_t), cfg.search_hz)
    assert fidelity.body_in_notch(f_peak, highpass_hz=full.highpass_hz, search_hz=cfg.search_hz)
    pw, ref, _ = fidelity.rotation_line_sums(
        st,
        f_peak,
        np.full((n_t, 4), REV_S),
        n_blades=N_BLADES,
        line_power=np.ones(cfg.rotation_orders + 1),
        highpass_hz=full.highpass_hz,
        cfg=cfg,
    )
    assert not ref.any() and not pw.any()
    # a flying body (60 Hz) is not in the notch: the features keep its line's peak
    assert not fidelity.body_in_notch(np.full(n_t, BODY_HZ), highpass_hz=full.highpass_hz, search_hz=cfg.search_hz)
    g = features(rotation_lines(12.0, rng, odd_rel=odd_rel), cfg, spec_cfg=full)
    assert not g.body_in_notch and np.isfinite(g.body_db).all()


def test_asymmetry_sign_and_size(rng):
    f = features(tones(6.0, rng, asym_db=-3.0))
    assert np.allclose(f.asymmetry_db, -3.0, atol=0.3)
    assert np.allclose(f.first_pair_db, 3.0, atol=0.3)  # the stronger (lower) side is 3 dB above the body


@pytest.mark.slow
def test_fading_std_and_timescale(rng):
    """Sidebands faded by an OU process of 3 dB std and 5 s timescale: the blade
    SNR's std over CPIs and its 1/e time come back; the body does not fade."""
    dur, tau, sd = 300.0, 5.0, 3.0
    n = int(dur * PRF_HZ)
    step = 64
    slow = ou_db(n // step + 1, step / PRF_HZ, tau, sd, rng)
    fade = np.interp(np.arange(n), np.arange(len(slow)) * step, slow)
    f = features(tones(dur, rng, fade_db=fade), fidelity.FidelityConfig(n_harmonics=2, max_lag_cpis=60))
    s = fidelity.summarise(f, np.ones(len(f.time_s), bool), fidelity.FidelityConfig(max_lag_cpis=60))
    # the realisation's own std over CPIs (300 s hold ~60 timescales)
    truth = np.interp(f.time_s, np.arange(n) / PRF_HZ, fade).std(ddof=1)
    assert abs(s["blade_std_db"] - truth) < 0.15 * truth  # CPI power averaging compresses dB swings a little
    assert 0.6 * sd < s["blade_std_db"] < 1.4 * sd
    assert 0.6 * tau < s["blade_timescale_s"] < 1.5 * tau
    assert s["body_std_db"] < 0.6


def test_timescale_uses_only_masked_pairs():
    x = np.tile([0.0, 1.0], 40)  # alternates: 1/e crossed at lag 1 over all CPIs
    assert fidelity.correlation_timescale_s(x, np.ones(80, bool), 0.5, 10) < 0.5
    slow = np.repeat([0.0, 1.0, 0.0, 1.0, 0.0], 16)
    mask = folds(80, 8) == 1
    assert fidelity.correlation_timescale_s(slow, mask, 0.5, 4) == 2.0  # censored at 4 lags
    assert np.isnan(fidelity.correlation_timescale_s(slow, np.zeros(80, bool), 0.5, 4))


def test_clutter_floor_sees_a_raised_skirt(rng):
    """Noise added only 20-40 Hz from zero Doppler raises the floor next to the clutter line."""
    iq = tones(6.0, rng)
    n = len(iq)
    skirt = (
        np.fft.ifft(
            np.where(
                (np.abs(np.fft.fftfreq(n, 1 / PRF_HZ)) > 20) & (np.abs(np.fft.fftfreq(n, 1 / PRF_HZ)) < 40),
                rng.standard_normal(n) + 1j * rng.standard_normal(n),
                0,
            )
        )
        * np.sqrt(n)
        * 3
    )
    base, raised = features(iq), features((iq + skirt).astype(np.complex64))
    lift = np.nanmean(raised.floor_db) - np.nanmean(base.floor_db)
    assert np.nanmean(np.abs(base.floor_db)) < 1.5  # white noise: the floor is the median floor
    assert lift > 10


def test_distances_zero_for_identical_and_positive_for_a_wrong_twin(rng):
    cfg = fidelity.FidelityConfig(n_harmonics=3)
    a = features(tones(16.0, rng), cfg)  # >= nonmultiple_min_cpis scored CPIs
    mask = folds(len(a.time_s), 4) == 1
    d0 = fidelity.distances(a, a, mask, cfg)
    assert list(d0) == list(fidelity.DISTANCES)
    assert all(v == 0.0 for v in d0.values()), d0
    b = features(tones(16.0, rng, asym_db=0.0), cfg)
    d1 = fidelity.distances(a, b, mask, cfg)
    assert abs(d1["asymmetry_db"] - 6.0) < 0.5 and d1["line_hz"] < 0.2


def per_flight_frame(rng, n_flights=12):
    rows = []
    for i in range(n_flights):
        base = rng.uniform(1, 3, len(fidelity.DISTANCES))
        for v, shift in (("sub_cpi", 0.0), ("per_cpi", 0.0), ("fixed_speeds", 2.0)):
            d = base + shift + 0.01 * rng.standard_normal(len(base))
            rows.append({"flight_id": f"f{i}", "variant": v, **dict(zip(fidelity.DISTANCES, d))})
    df = pd.DataFrame(rows)
    df.loc[(df.flight_id == "f0") & (df.variant == "per_cpi"), "line_hz"] = np.nan  # a flight without lines
    return df


def test_table_columns_intervals_and_paired_rows(rng):
    t = fidelity.fidelity_table(per_flight_frame(rng), n_boot=400, seed=1)
    assert list(t.variant) == ["sub_cpi", "per_cpi", "fixed_speeds", "sub_cpi - per_cpi", "per_cpi - fixed_speeds"]
    for m in fidelity.DISTANCES:
        for c in ("mean", "ci95_low", "ci95_high", "resolved"):
            assert f"{m}_{c}" in t.columns
        main = t.iloc[:3]
        assert (main[f"{m}_ci95_low"] <= main[f"{m}_mean"]).all() and (
            main[f"{m}_mean"] <= main[f"{m}_ci95_high"]
        ).all()
    assert t.loc[1, "n_flights"] == 12 and t.loc[0, "n_flights"] == 12
    # sub_cpi and per_cpi differ by noise only: the paired interval is narrow and holds 0
    d = t.iloc[3]
    assert d["blade_std_db_ci95_high"] - d["blade_std_db_ci95_low"] < 0.05
    assert not d["blade_std_db_resolved"]
    assert fidelity.pairs(["fixed_speeds", "extended", "sub_cpi"]) == [
        ("sub_cpi", "fixed_speeds"),
        ("extended", "sub_cpi"),
    ]


def test_table_resolves_a_real_difference(rng):
    df = per_flight_frame(rng)
    df.loc[df.variant == "fixed_speeds", "variant"] = "single_motor"
    t = fidelity.fidelity_table(df, n_boot=400, seed=1).set_index("variant")
    row = t.loc["per_cpi - single_motor"]
    assert row["floor_db_resolved"] and row["floor_db_ci95_high"] < -1.5 and abs(row["floor_db_mean"] + 2) < 0.1


def test_extended_rows_per_extension_source(rng):
    """Twins carrying their own flight's causes get closer, population-drawn ones do not:
    the per-source rows separate what the mixed ``extended - sub_cpi`` row blurs."""
    rows = []
    for i in range(24):
        base = rng.uniform(1, 3, len(fidelity.DISTANCES))
        own = i % 2 == 0
        for v, shift, src in (("sub_cpi", 0.0, ""), ("extended", -1.0 if own else 0.3, "own" if own else "population")):
            d = base + shift + 0.05 * rng.standard_normal(len(base))
            rows.append(
                {"flight_id": f"f{i}", "variant": v, "extension_source": src, **dict(zip(fidelity.DISTANCES, d))}
            )
    t = fidelity.fidelity_table(pd.DataFrame(rows), n_boot=400, seed=1).set_index("variant")
    assert list(t.index[-2:]) == ["extended [own] - sub_cpi", "extended [population] - sub_cpi"]
    own, pop, mixed = (
        t.loc["extended [own] - sub_cpi"],
        t.loc["extended [population] - sub_cpi"],
        t.loc["extended - sub_cpi"],
    )
    assert own["n_flights"] == 12 and pop["n_flights"] == 12 and mixed["n_flights"] == 24
    assert own["asymmetry_db_resolved"] and own["asymmetry_db_ci95_high"] < -0.9
    assert pop["asymmetry_db_resolved"] and pop["asymmetry_db_ci95_low"] > 0.2
    assert abs(mixed["asymmetry_db_mean"] - (-0.35)) < 0.05
    # one source only (or no column): no extra rows
    one = pd.DataFrame(rows)
    one["extension_source"] = "own"
    assert not fidelity.fidelity_table(one, n_boot=50, seed=1).variant.str.contains(r"\[").any()


def test_scoring_mask_is_the_complement_of_the_fit_fold():
    cfg = calibration.CalibrationConfig(holdout_block_cpis=8)
    fit = cfg.fit_mask(41)
    score, held = fidelity.scoring_mask({"holdout_block_cpis": 8}, 41)
    assert held and not (fit & score).any() and (fit | score).all()
    assert fit[:8].all() and not fit[8:16].any()
    custom, held = fidelity.scoring_mask({"holdout_block_cpis": None, "fit_cpis": [0, 2, 5]}, 6)
    assert held and custom.tolist() == [False, True, False, True, True, False]
    everything, held = fidelity.scoring_mask({"holdout_block_cpis": 0}, 6)
    assert everything.all() and not held
    assert calibration.CalibrationConfig(holdout_block_cpis=0).fit_mask(5).all()
    with pytest.raises(ValueError, match="holdout_block_cpis"):
        calibration.CalibrationConfig(holdout_block_cpis=-1)


@pytest.fixture(scope="module")
def drone():
    fl = make_flight("ins1", "drone", duration_s=12.0, seed=11, drone_model="inspire2")
    return fl, MotorLog(np.asarray(fl.motors_time_s, float), np.asarray(fl.motors_rpm, np.float32), "test")


def test_calibration_targets_ignore_held_out_cpis(drone):
    """The fit's targets come from fold A only: garbling the held-out CPIs of the
    measured spectrogram leaves them unchanged (and changes them without a hold-out)."""
    fl, log = drone
    targets = {}
    for block in (8, 0):
        cfg = calibration.CalibrationConfig(holdout_block_cpis=block)
        meter = calibration.TwinMeter(fl, SPEC, cfg)
        rate, spread = log_rate_at(log.time_s, log.rev_s, meter.time_s)
        held = ~cfg.fit_mask(len(meter.time_s)) if block else folds(len(meter.time_s), 8) == 1
        for garble in (False, True):
            spec = spectrogram(fl.iq, fl.prf_hz, SPEC)
            if garble:
                spec.power_db[held] = np.random.default_rng(5).normal(0, 30, spec.power_db[held].shape)
            t = calibration.LineTargets.of(meter.lines(spec, rate, float(np.percentile(spread, 90))), 10.0)
            targets[block, garble] = (t.body_db, t.sideband1_db, t.n_pairs)
    assert targets[8, False] == targets[8, True]
    assert targets[0, False] != targets[0, True]


def test_fit_twin_records_its_fold(drone):
    fl, log = drone
    rev = np.repeat(np.asarray(log.rev_s[:1], np.float32), len(fl.iq), axis=0)
    cfg = calibration.CalibrationConfig(n_alpha=1, max_iter=1, holdout_block_cpis=8)
    _, res = calibration.fit_twin(fl, rev, log, spec_cfg=SPEC, cfg=cfg, seed=3)
    n_t = res["n_cpis"]
    assert res["holdout_block_cpis"] == 8 and res["n_fit_cpis"] == int((folds(n_t, 8) == 0).sum()) < n_t
    score, held = fidelity.scoring_mask(res, n_t)
    assert held and score.sum() == n_t - res["n_fit_cpis"]
    mask = np.zeros(n_t, bool)
    mask[::3] = True
    _, res = calibration.fit_twin(fl, rev, log, spec_cfg=SPEC, cfg=cfg, seed=3, fit_mask=mask)
    assert res["holdout_block_cpis"] is None and res["fit_cpis"] == np.flatnonzero(mask).tolist()
    assert (fidelity.scoring_mask(res, n_t)[0] == ~mask).all()


def test_measured_features_stored_once_read_back_unchanged(drone, tmp_path):
    """The measured flight's features (rule measure_flights) come back from the store
    bit for bit, so every variant's score_twins scores against the same numbers as
    measuring the flight itself."""
    from microdoppler.datasets.stores import writing_store

    fl, log = drone
    f = fidelity.flight_features(fl, fl.iq, log, spec_cfg=SPEC)
    with writing_store(tmp_path / "features.zarr", {"schema": fidelity.FEATURES_SCHEMA}) as root:
        fidelity.write_features(root.require_group(fl.flight_id), f)
    back = fidelity.read_measured_features(tmp_path / "features.zarr")[fl.flight_id]
    for name, value in vars(f).items():
        if isinstance(value, np.ndarray):
            got = getattr(back, name)
            assert got.dtype == value.dtype and np.array_equal(got, value, equal_nan=True), name
        else:
            assert getattr(back, name) == value, name


def test_variant_scores_round_trip_exactly(tmp_path, rng):
    """A variant's scores written by score_twins read back with the same values and
    types (NaN, empty text, booleans), so Table VI from the files equals Table VI
    from the frames."""
    n = 12
    frames = []
    for v in ("sub_cpi", "extended"):
        d = {k: rng.normal(size=n) * 10 ** rng.uniform(-8, 3, n) for k in fidelity.DISTANCES}
        d["n_pairs"][:2] = np.nan
        frames.append(
            pd.DataFrame(
                {
                    "flight_id": [f"f{i:02d}" for i in range(n)],
                    "variant": v,
                    "drone_model": ["inspire2", ""] * (n // 2),
                    "held_out": True,
                    "n_cpis_scored": rng.integers(0, 40, n),
                    "extension_source": ["", "own flight"] * (n // 2),
                    **d,
                    "lines_visible": rng.random(n) > 0.3,
                    "body_in_notch": rng.random(n) > 0.7,
                }
            )
        )
    back = []
    for df in frames:
        fidelity.write_scores(df, tmp_path / "s.csv")
        got = fidelity.read_scores(tmp_path / "s.csv")
        pd.testing.assert_frame_equal(got, df[fidelity.SCORE_COLUMNS], check_dtype=False)
        for c in fidelity.DISTANCES:
            assert np.array_equal(got[c].to_numpy(), df[c].to_numpy(), equal_nan=True), c
        back.append(got)
    direct = fidelity.fidelity_table(pd.concat(frames, ignore_index=True), n_boot=200, seed=1)
    via_files = fidelity.fidelity_table(pd.concat(back, ignore_index=True), n_boot=200, seed=1)
    pd.testing.assert_frame_equal(direct, via_files)


@pytest.mark.slow
def test_rule_wires_every_variant(tmp_path):
    """``report_fidelity`` is part of the default target and reads every variant's
    injected twins, the measured flights and the motor logs (dry run)."""
    repo = Path(__file__).resolve().parents[1]
    work = new_workdir(tmp_path)
    exe = shutil.which("snakemake") or str(Path(sys.executable).with_name("snakemake"))
    r = subprocess.run(
        [exe, "-n", "-s", str(repo / "Snakefile"), "-d", str(work), "--configfile", "config/test.yaml"],
        cwd=work,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    job = r.stdout[r.stdout.index("rule report_fidelity:") :].split("\n\n")[0]
    for path in (
        "results/injected/sub_cpi.zarr",
        "results/injected/fixed_speeds.zarr",
        "results/fidelity/sub_cpi.csv",
        "results/fidelity/fixed_speeds.csv",
        "results/measured",
        "results/motors/logs.zarr",
        "results/reports/table_vi.csv",
        "results/reports/fig_fidelity.png",
    ):
        assert path in job, (path, job)
    # each variant scored by its own job, against the flights measured once
    scoring = [b for b in r.stdout.split("[") if b.lstrip().split("\n", 1)[-1].startswith("rule score_twins:")]
    for v in ("sub_cpi", "fixed_speeds"):
        (job,) = [b for b in scoring if f"output: results/fidelity/{v}.csv" in b]
        assert f"results/injected/{v}.zarr" in job and "results/fidelity/measured.zarr" in job, job
    assert r.stdout.count("rule measure_flights:") == 1
