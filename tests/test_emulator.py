"""Tests of the measurement emulator (issue 3): physics measured with the pipeline's
own spectrogram chain, determinism, format validity, knobs, motor-log calibration."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from microdoppler.emulator import FlightSpec, emulate_flight, emulate_world, plan_world
from microdoppler.emulator.knobs import validate_effects
from microdoppler.io.flightzarr import validate_store
from microdoppler.io.motorlog import read_csv
from microdoppler.spectra.snr import line_snr_db, noise_floor_db
from microdoppler.spectra.spectrogram import SpectrogramConfig, spectrogram

FULL = SpectrogramConfig(n_bins=0)


@pytest.fixture
def rng():
    return np.random.default_rng(20261121)


def _drone(rng, model="inspire2", **kw):
    base = dict(
        flight_id="x",
        target="drone",
        drone_model=model,
        radar_id="radar1",
        duration_s=12.0,
        mean_range_m=1200.0,
        height_m=80.0,
        speed_mps=6.0,
        seed=int(rng.integers(2**31)),
        snr_db=45.0,
        wind_mps=2.0,
        with_background=False,
    )
    base.update(kw)
    return FlightSpec(**base)


def _body_doppler(flight, spec):
    v = np.interp(spec.time_s, flight.track_time_s, flight.track_radial_velocity_mps)
    return -2 * v / flight.wavelength_m


def _sideband_levels(flight, truth, n_harm=7, upper=True):
    """Per timestep: body peak and the k-th sideband group peaks over the median floor [dB]."""
    sp = spectrogram(flight.iq, flight.prf_hz, FULL)
    fb = _body_doppler(flight, sp)
    floor = noise_floor_db(sp)
    if flight.has_motor_log:  # HERM spacing = blades x mean rotation rate, per timestep
        spacing = 2 * np.interp(sp.time_s, flight.motors_time_s, flight.motors_rpm.mean(1)) / 60.0
    else:
        spacing = 2 * np.mean(truth["motors"]["mean_rev_s"])
    body = line_snr_db(sp, fb, search_hz=6.0)
    out, ref = [], []
    for k in range(1, n_harm + 1):
        w = float(np.median(0.05 * k * spacing + 6.0))
        sgn = 1 if upper else -1
        out.append(line_snr_db(sp, fb + sgn * k * spacing, search_hz=w))
        # a window of the same width beyond the blade-tip Doppler (< 1 kHz) holds noise only
        ref.append(line_snr_db(sp, fb + sgn * (1500.0 + 3 * k * w), search_hz=w))
    _sideband_levels.noise = np.array(ref)
    return body, np.array(out), floor


def test_large_drone_sidebands_match_paper(rng):
    """§V.A.2: 3-5 sideband pairs at short range, first 5-10 dB below the body,
    3-8 dB per further harmonic (the world draws 4-16 dB per motor line; the text's
    short-range flights are the lower part, 4-7 dB)."""
    for model in ("inspire2", "matrice300"):
        spec = _drone(rng, model, snr_db=42.0, harmonic_falloff_db=float(rng.uniform(4.0, 7.0)))
        f, tr = emulate_flight(spec)
        body, sb, _ = _sideband_levels(f, tr)
        nu = _sideband_levels.noise
        _, sbl, _ = _sideband_levels(f, tr, upper=False)
        nl = _sideband_levels.noise
        b = np.median(body)
        s = np.median(0.5 * (sb + sbl), axis=1)  # mean of upper and lower, median over time
        noise = np.median(0.5 * (nu + nl), axis=1)
        first_below = b - s[0]
        assert 5.0 <= first_below <= 10.5, (model, first_below)
        visible = int(np.sum(s > noise + 3.0))  # sideband groups 3 dB above a noise-only window
        assert 3 <= visible <= 5, (model, s)
        steps = -np.diff(s[:visible])
        assert 3.0 <= np.mean(steps) <= 8.0, (model, steps)
        assert np.all((steps > 2.0) & (steps < 10.0)), (model, steps)


def test_steep_falloff_ends_sidebands_after_one_or_two_pairs(rng):
    """Table IV's large alphas (up to 8e-2 s): flights whose sidebands end early. The
    world's steepest draws (16 dB per motor line) leave at most two visible pairs at
    the same SNR where 4-7 dB leave 3-5, and each further pair falls > 8 dB."""
    spec = _drone(rng, "inspire2", snr_db=42.0, harmonic_falloff_db=16.0)
    f, tr = emulate_flight(spec)
    body, sb, _ = _sideband_levels(f, tr)
    nu = _sideband_levels.noise
    s, noise = np.median(sb, axis=1), np.median(nu, axis=1)
    visible = int(np.sum(s > noise + 3.0))
    assert 1 <= visible <= 2, s - noise
    assert s[0] - s[1] > 8.0, s


@pytest.mark.slow
def test_world_draws_falloff_over_table_iv_range():
    """The paper profile's large drones span gentle (text: 3-8 dB) to steep fall-offs."""
    from microdoppler.emulator.world import FALLOFF_DB

    specs = [s for s in plan_world("paper", 3) if s.drone_model in ("inspire2", "matrice300")][:60]
    falls = []
    for s in specs:
        _, tr = emulate_flight(replace(s, duration_s=1.0, with_background=False))
        falls.append(tr["harmonic_falloff_db"])
    falls = np.array(falls)
    assert np.all((falls >= FALLOFF_DB[0]) & (falls <= FALLOFF_DB[1]))
    # log-uniform: P(<= 8 dB) = 0.5, P(> 10 dB) = 0.34; 60 flights, > 3 sigma margins
    assert np.mean(falls <= 8.0) >= 0.3 and np.mean(falls > 10.0) >= 0.15, falls


def test_weak_blades_sink_the_sidebands(rng):
    """World v3: a weak-blade flight's first sideband sits WEAK_BLADE_DB below the body
    (the same seed with normal blades: 5-10.5 dB); the worlds mark about
    WEAK_BLADE_SHARE of their large drones, never a Mini or a bird."""
    from microdoppler.emulator.world import WEAK_BLADE_DB, WEAK_BLADE_SHARE

    seed = int(rng.integers(2**31))
    below = {}
    for weak in (False, True):
        spec = _drone(rng, "inspire2", seed=seed, snr_db=50.0, harmonic_falloff_db=5.0, weak_blades=weak)
        f, tr = emulate_flight(spec)
        body, sb, _ = _sideband_levels(f, tr, n_harm=1)
        _, sbl, _ = _sideband_levels(f, tr, n_harm=1, upper=False)
        below[weak] = float(np.median(body) - np.median(0.5 * (sb[0] + sbl[0])))
        assert tr["weak_blades"] is weak
    assert 5.0 <= below[False] <= 10.5, below
    # the measured line has the noise under it: at 50 dB body SNR a sideband 20-35 dB
    # down stands 15-30 dB over the floor, so the measurement reads it within ~1 dB
    assert WEAK_BLADE_DB[0] - 3.0 <= below[True] <= WEAK_BLADE_DB[1] + 1.0, below
    specs = plan_world("paper", 5)
    large = [s for s in specs if s.drone_model in ("inspire2", "matrice300")]
    share = np.mean([s.weak_blades for s in large])
    # 121 large drones: binomial sd 0.042
    assert abs(share - WEAK_BLADE_SHARE) < 0.13, share
    assert not any(s.weak_blades for s in specs if s.drone_model not in ("inspire2", "matrice300"))


def test_birds_manoeuvre_and_mini_wander_are_drawn():
    """World v3: bird groups turn and surge by drawn amounts (their radial velocity
    wanders more than without), and the Mini's wander scales with ``wander_m``."""
    from microdoppler.emulator.bird import SPEED_SURGE, TURN_RATE_SD_RAD_S, plan_group
    from microdoppler.emulator.drone import loop_path

    def vr_wobble(g):  # radial velocity's deviation from a straight fit, over 20 s
        v = np.gradient(g.centre_range_m, g.t_s)
        return float(np.std(v - np.polyval(np.polyfit(g.t_s, v, 2), g.t_s)))

    calm, manoeuvring = [], []
    for k in range(12):
        kw = dict(duration_s=20.0, mean_range_m=1000.0, height_m=60.0, speed_mps=12.0)
        g0 = plan_group("single", rng=np.random.default_rng([k, 1]), **kw)
        g1 = plan_group("single", rng=np.random.default_rng([k, 1]), manoeuvre_rng=np.random.default_rng([k, 8]), **kw)
        assert TURN_RATE_SD_RAD_S[0] <= g1.turn_rate_sd <= TURN_RATE_SD_RAD_S[1]
        assert SPEED_SURGE[0] <= g1.speed_surge <= SPEED_SURGE[1]
        assert g0.turn_rate_sd == 0.0 and g0.speed_surge == 0.0
        calm.append(vr_wobble(g0))
        manoeuvring.append(vr_wobble(g1))
    assert np.median(manoeuvring) > 1.5 * np.median(calm), (calm, manoeuvring)

    def wander(w):
        p = loop_path(
            60.0,
            mean_range_m=1500.0,
            height_m=80.0,
            speed_mps=6.0,
            direction=1,
            hand_flown=True,
            rng=np.random.default_rng(3),
            wander_m=w,
        )
        return p.pos_m

    base = loop_path(
        60.0,
        mean_range_m=1500.0,
        height_m=80.0,
        speed_mps=6.0,
        direction=1,
        hand_flown=True,
        rng=np.random.default_rng(3),
        wander_m=0.0,
    ).pos_m
    d1 = np.std(wander(1.5)[:, :2] - base[:, :2])
    d5 = np.std(wander(5.0)[:, :2] - base[:, :2])
    assert d5 == pytest.approx(d1 * 5.0 / 1.5, rel=1e-6), (d1, d5)


def test_mini_has_no_visible_sidebands(rng):
    spec = _drone(rng, "mini2", snr_db=40.0)
    f, tr = emulate_flight(spec)
    body, sb, _ = _sideband_levels(f, tr, n_harm=2)
    assert np.median(body) > 30
    # a noise-only search window reaches ~8-11 dB over the median; a line would be above
    assert np.median(sb[0]) < 13.0


#: lines closer than this are one line: the Blackman-Harris main lobe is +-4 bins
#: (1.78 Hz each) per line, and 8 bins = 14.3 Hz exceeds the fastest wingbeat (starling,
#: 13 Hz), so a bird's own first wingbeat sidelines count as part of its line
LINE_SEPARATION_BINS = 8
#: "one dominant line": the strongest line stands >= this far above the strongest other
#: line (median over timesteps). A single bird's other lines are its wing echo (8-22 dB
#: below the body amplitude, emulator.bird.WING_BELOW_BODY_DB, spread over Bessel lines
#: J_n(k A_wing), k A_wing >= 2.2, each <= ~0.55 of that) and its second wingbeat
#: sidelines (body phase modulation k x 0.01 m = 0.57 rad: J2/J0 = -27 dB). A large
#: flock's 12-30 birds sit up to 8 dB below the leader with a 3 m/s (27 Hz) velocity
#: spread, so several lines come within a few dB of each other.
DOMINANT_MARGIN_DB = 8.0


def _bird_lines(flight):
    """Per timestep, within +-60 Hz of the body Doppler: the strongest spectral peak's
    offset from the body Doppler [Hz] and its margin [dB] over the strongest other peak
    at least LINE_SEPARATION_BINS away; and the number of local maxima 15 dB over the
    median (the flock's line count)."""
    from scipy.signal import find_peaks

    sp = spectrogram(flight.iq, flight.prf_hz)
    fb = _body_doppler(flight, sp)
    offsets, margins, counts = [], [], []
    for i in range(sp.power_db.shape[0]):
        p = sp.power_db[i] - np.median(sp.power_db[i])
        sel = np.abs(sp.doppler_hz - fb[i]) < 60
        q, fq = p[sel], sp.doppler_hz[sel]
        pk, _ = find_peaks(q)
        order = pk[np.argsort(q[pk])[::-1]]
        top = order[0]
        others = [j for j in order[1:] if abs(fq[j] - fq[top]) > LINE_SEPARATION_BINS * sp.bin_hz]
        offsets.append(fq[top] - fb[i])
        margins.append(q[top] - q[others[0]] if others else q[top])
        counts.append(int(np.sum(q[pk] > 15)))
    return np.array(offsets), np.array(margins), np.array(counts), sp.bin_hz


def test_flock_shows_several_body_lines(rng):
    spec = FlightSpec(
        "fl",
        "bird",
        bird_kind="large_flock",
        duration_s=10.0,
        mean_range_m=900.0,
        speed_mps=12.0,
        seed=int(rng.integers(2**31)),
        snr_db=40.0,
        with_background=False,
    )
    f, tr = emulate_flight(spec)
    assert tr["n_birds"] >= 12
    _, margins, counts, _ = _bird_lines(f)
    assert np.median(counts) >= 3, counts
    # no single line dominates: another bird's line is within a few dB of the strongest
    assert np.median(margins) < DOMINANT_MARGIN_DB, np.median(margins)


def test_single_bird_has_one_dominant_line(rng):
    """Measured in the spectrum of emulated single-bird flights (four seeds, random
    species): the strongest line sits on the body Doppler and stands at least
    DOMINANT_MARGIN_DB above any other line more than 14 Hz away (median over timesteps),
    where a flock (test above) does not."""
    for _ in range(4):
        spec = FlightSpec(
            "one",
            "bird",
            bird_kind="single",
            duration_s=10.0,
            mean_range_m=900.0,
            speed_mps=12.0,
            seed=int(rng.integers(2**31)),
            snr_db=40.0,
            with_background=False,
        )
        f, tr = emulate_flight(spec)
        assert tr["n_birds"] == 1
        offsets, margins, _, bin_hz = _bird_lines(f)
        assert np.median(np.abs(offsets)) <= 2 * bin_hz, (tr["species"], np.median(np.abs(offsets)))
        assert np.median(margins) >= DOMINANT_MARGIN_DB, (tr["species"], np.median(margins))


def test_radar2_floor_near_clutter_is_raised(rng):
    """Same cells, same clutter: radar 2's phase noise raises the floor near zero Doppler."""
    seed = int(rng.integers(2**31))
    lv = {}
    for rid in ("radar1", "radar2"):
        spec = _drone(rng, "mini2", radar_id=rid, seed=seed, snr_db=20.0, clutter_scale_db=5.0, with_background=True)
        f, _ = emulate_flight(spec)
        sp = spectrogram(f.background_iq, f.prf_hz)
        near = (np.abs(sp.doppler_hz) > 20) & (np.abs(sp.doppler_hz) < 80)
        far = np.abs(sp.doppler_hz) > 300
        lv[rid] = float(np.median(sp.power_db[:, near]) - np.median(sp.power_db[:, far]))
    assert lv["radar2"] > lv["radar1"] + 3.0, lv


def test_same_seed_identical_arrays(rng):
    spec = _drone(
        rng,
        "inspire2",
        duration_s=6.0,
        with_background=True,
        effects={"sideband_fading": {"fading_std_db": 4.0, "timescale_s": 1.0}},
    )
    a, ta = emulate_flight(spec)
    b, tb = emulate_flight(spec)
    for k, v in a.arrays().items():
        assert v.tobytes() == b.arrays()[k].tobytes(), k
    c, _ = emulate_flight(replace(spec, seed=spec.seed + 1))
    assert c.iq.tobytes() != a.iq.tobytes()


def test_effects_validated_against_catalog():
    assert validate_effects({"sideband_fading": {"fading_std_db": 3.0}})["sideband_fading"]["timescale_s"] > 0
    with pytest.raises(ValueError, match="not a catalog cause"):
        validate_effects({"wobble": {}})
    with pytest.raises(ValueError, match="unknown"):
        validate_effects({"motor_log_lag": {"lag": 1.0}})
    with pytest.raises(ValueError, match="missing"):
        validate_effects({"phase_noise": {}})
    assert validate_effects({"blade_imbalance": {"imbalance_db": 6}}) == {"blade_imbalance": {"imbalance_db": 6.0}}
    with pytest.raises(ValueError, match="imbalance_db"):
        validate_effects({"blade_imbalance": {"imbalance_db": -3.0}})


def test_sideband_asymmetry_sign_and_size(rng):
    for a in (6.0, -6.0):
        spec = _drone(rng, "inspire2", effects={"sideband_asymmetry": {"asymmetry_db": a}})
        f, tr = emulate_flight(spec)
        _, up, _ = _sideband_levels(f, tr, n_harm=2)
        _, lo, _ = _sideband_levels(f, tr, n_harm=2, upper=False)
        d = float(np.median(up[:2] - lo[:2]))
        assert abs(d - a) < 2.5, (a, d)


def test_motor_log_lag_and_scale(rng):
    """A row stamped t reports true(t - lag) / scale."""
    spec = _drone(rng, "inspire2", duration_s=20.0, speed_mps=10.0, wind_mps=6.0)
    f0, _ = emulate_flight(spec)
    lag, scale = 0.5, 1.1
    f1, _ = emulate_flight(
        replace(spec, effects={"motor_log_lag": {"lag_s": lag}, "motor_speed_scale": {"scale": scale}})
    )
    assert np.allclose(f0.iq, f1.iq)  # the radar data are unchanged
    m0 = f0.motors_rpm.mean(1)
    m1 = np.interp(f0.motors_time_s + lag, f1.motors_time_s, f1.motors_rpm.mean(1)) * scale
    ok = (f0.motors_time_s + lag) < f1.motors_time_s[-1]
    assert np.median(np.abs(m1[ok] - m0[ok]) / m0[ok]) < 0.01
    m1_wrong = np.interp(f0.motors_time_s - lag, f1.motors_time_s, f1.motors_rpm.mean(1)) * scale
    assert np.median(np.abs(m1_wrong[ok] - m0[ok])) > np.median(np.abs(m1[ok] - m0[ok]))
    # log rate and quantisation
    dt = np.diff(f0.motors_time_s)
    assert abs(np.median(dt) - 1 / 30) < 0.003 and np.all(dt > 0)
    assert np.all(f0.motors_rpm == np.round(f0.motors_rpm))


def test_phase_noise_knob_raises_skirt(rng):
    spec = _drone(rng, "mini2", snr_db=20.0, clutter_scale_db=0.0, radar_id="radar1")
    lv = []
    for eff in ({}, {"phase_noise": {"rms_rad": 0.02}}):
        f, _ = emulate_flight(replace(spec, effects=eff))
        sp = spectrogram(f.iq, f.prf_hz)
        near = (np.abs(sp.doppler_hz) > 20) & (np.abs(sp.doppler_hz) < 90)
        lv.append(np.median(sp.power_db[:, near]))
    assert lv[1] > lv[0] + 6.0


def _skirt_bands(iq, prf_hz):
    """Mean power spectrum (the pipeline's STFT, no high-pass, all bins) summed over the
    line at 0 Hz (+-8 bins), the skirt 35-95 Hz on each side, and 110-300 Hz."""
    sp = spectrogram(iq, prf_hz, SpectrogramConfig(n_bins=0, highpass_hz=0.0))
    P = np.mean(10 ** (sp.power_db.astype(np.float64) / 10), axis=0)
    f = sp.doppler_hz
    return {
        "line": P[np.abs(f) <= 8 * sp.bin_hz].sum(),
        "upper": P[(f >= 35) & (f <= 95)].sum(),
        "lower": P[(f <= -35) & (f >= -95)].sum(),
        "beyond": P[(np.abs(f) >= 110) & (np.abs(f) <= 300)].sum(),
        # the bins summed as "upper" span this many Hz (34 bins x 1.78 Hz = 60.6 Hz)
        "width_hz": np.count_nonzero((f >= 35) & (f <= 95)) * sp.bin_hz,
    }


def test_phase_noise_knob_skirt_matches_small_angle_theory():
    """The knob as the emulator applies it (background.record: clutter x exp(j theta),
    then thermal noise), measured in the spectrum of a strong stationary clutter line
    (60 dB clutter-to-noise per pulse, one cell, radar 1). Small-angle theory for a
    Gaussian phase error of rms s with a flat spectrum on |f| < 100 Hz:
    exp(j theta) ~ 1 + j theta, so each 60 Hz skirt band 35-95 Hz holds s^2 x 60 / 200
    of the line's power (second order: + s^4 / 2 x 0.2025, 1e-4 of that at s = 0.02).
    The skirt added by the knob (run with the knob minus the same run without it:
    radar 1's own phase noise and the thermal noise cancel) is compared with that, and
    the knob adds nothing beyond 110 Hz at first order. The band's width is that of the
    STFT bins summed (34 x 1.78 = 60.6 Hz). Measured over 12 seeds: -0.05 to +0.08 dB
    from theory (seed 11, used here: -0.02 dB; the random spectrum of theta over ~2000
    frequency cells fluctuates by ~2 %); tolerance 0.4 dB. An rms off by 10 % (0.8 dB) or a band of
    150 Hz instead of 100 (-1.8 dB) fails."""
    from microdoppler.emulator import background as bg
    from microdoppler.emulator.radars import RADARS

    rms, n = 0.02, 1 << 18
    site = replace(RADARS["radar1"], clutter_cnr_db=(60.0, 60.0))
    prf = site.radar.prf_hz
    t_track = np.arange(0.0, n / prf + 1.0, 0.1)
    cells = np.zeros((len(t_track), 2), np.int64)  # one cell: stationary clutter at 0 Hz
    bands = {}
    for knob in (0.0, rms):
        iq, _ = bg.record(
            None,
            n,
            t_track_s=t_track,
            cells=cells,
            site=site,
            site_seed=1,
            wind_mps=2.0,
            rng=np.random.default_rng(11),
            knob_phase_rms_rad=knob,
        )
        bands[knob] = _skirt_bands(iq, prf)
    on, off = bands[rms], bands[0.0]
    expected = rms**2 * on["width_hz"] / 200.0
    for side in ("upper", "lower"):
        added = (on[side] - off[side]) / on["line"]
        assert abs(10 * np.log10(added / expected)) < 0.4, (side, added, expected)
        assert off[side] < 0.05 * on[side], (side, off[side], on[side])  # the knob dominates the skirt
    # beyond the knob's 100 Hz band only second-order terms (s^4 / 2 x 0.2025 of the line)
    added_beyond = (on["beyond"] - off["beyond"]) / on["line"]
    assert abs(added_beyond) < 3 * rms**4 / 2 * 0.2025 + 1e-3 * expected, added_beyond


def test_record_parts_are_the_same_realisation_and_sum_to_the_recording():
    """background.record's ``parts`` (a diagnostic): each part is the realisation the
    full recording holds, so with no phase noise the parts add up to the recording
    exactly; without any part only the target is left; an unknown part is an error
    naming it. Radar 2 (artifacts on), 0.5 s, clutter 50 dB, wind 8 m/s."""
    from microdoppler.emulator import background as bg
    from microdoppler.emulator.radars import RADARS

    site = replace(RADARS["radar2"], clutter_cnr_db=(50.0, 50.0), artifact_rate_per_min=600.0)
    n = int(0.5 * site.radar.prf_hz)
    t_track = np.arange(0.0, 1.0, 0.1)
    cells = np.zeros((len(t_track), 2), np.int64)
    target = (3.0 * np.exp(2j * np.pi * 0.01 * np.arange(n))).astype(np.complex64)

    def rec(parts=bg.PARTS):
        return bg.record(
            target,
            n,
            t_track_s=t_track,
            cells=cells,
            site=site,
            site_seed=4,
            wind_mps=8.0,
            rng=np.random.default_rng(5),
            parts=parts,
        )[0]

    full = rec()
    assert np.array_equal(rec(bg.PARTS), full)
    np.testing.assert_array_equal(rec(frozenset()), target)
    additive = bg.PARTS - {"phase"}
    summed = sum(rec(frozenset({p})) - target for p in additive) + target
    np.testing.assert_allclose(summed, rec(additive), rtol=0, atol=1e-3 * np.abs(full).max())
    # the phase noise multiplies what came before it: removing it changes the recording
    assert np.abs(rec(bg.PARTS - {"phase"}) - full).max() > 0
    # each additive part is really there (a part that drew nothing would pass the sum)
    for p in additive:
        assert np.abs(rec(frozenset({p})) - target).max() > 0.1, p
    with pytest.raises(ValueError, match="unknown.*'wind'"):
        rec(frozenset({"wind"}))


@pytest.mark.slow
def test_world_test_profile(tmp_path):
    out = tmp_path / "world"
    key = tmp_path / "key.json"
    rows = emulate_world("test", 3, out, key_path=key, progress=False, workers=1)
    man = pd.read_csv(out / "flights.csv")
    assert list(man.columns) == [
        "flight_id",
        "target",
        "drone_model",
        "bird_kind",
        "radar_id",
        "duration_s",
        "mean_range_m",
        "mean_snr_db",
    ]
    assert len(man) == len(rows) == len(plan_world("test", 3))
    for fid in man.flight_id:
        fl = validate_store(out / f"{fid}.zarr")
        assert fl.background_iq is not None
    logs = pd.read_csv(out / "motor_logs.tsv", sep="\t")
    assert set(logs.columns) == {"flight_id", "motor_log", "format", "unit", "time_offset_s"}
    for _, r in logs.iterrows():
        log = read_csv(out / r.motor_log, n_motors=4)
        assert 30 < np.median(log.rev_s) < 120
    k = json.loads(key.read_text())
    assert set(k["flights"]) == set(man.flight_id)
    assert any(v["effects"] for v in k["flights"].values())


def test_plans_are_deterministic_and_sized():
    a, b = plan_world("default", 11), plan_world("default", 11)
    assert a == b
    assert 40 <= len(a) <= 60
    assert {s.radar_id for s in a} == {"radar1", "radar2"}
    assert sum(1 for s in a if s.effects) >= 4
    p = plan_world("paper", 11)
    counts = pd.Series([s.cls for s in p]).value_counts().to_dict()
    assert counts == {"bird": 491, "inspire2": 69, "matrice300": 52, "mini2": 62}
    cfg = SpectrogramConfig()
    for cls, n_img in {"bird": 5814, "inspire2": 2183}.items():
        tiles = sum(
            (1 + (int(round(s.duration_s * 7300)) - 4096) // 2048) // cfg.tile_timesteps for s in p if s.cls == cls
        )
        assert abs(tiles - n_img) <= 0.02 * n_img


def _effects_by_model(plan, airframes=True):
    """Per drone model, its flights' effects (without the airframes' ``blade_imbalance``
    unless ``airframes``)."""

    def eff(s):
        return dict(s.effects) if airframes else {c: p for c, p in dict(s.effects).items() if c != "blade_imbalance"}

    return {m: [eff(s) for s in plan if s.drone_model == m] for m in ("inspire2", "matrice300", "mini2")}


@pytest.mark.parametrize("profile", ["default", "paper"])
def test_world_effects_have_a_population_structure(profile):
    """Per large model: one systematic asymmetry (same sign, within +-0.5 dB of the
    world's per-model value, on most flights), per-flight effects on top, >= 30 % of
    flights with two effects, some clean flights; Minis clean; no fixed cycle; all
    from the seed, and a different seed gives a different world."""
    from microdoppler.causes.catalog import CAUSES
    from microdoppler.emulator.profiles import PER_FLIGHT, world_population

    for seed in (11, 20221, 5):
        plan = plan_world(profile, seed)
        assert plan == plan_world(profile, seed)
        pop = world_population(seed)
        by = _effects_by_model(plan, airframes=False)  # the airframes' imbalance: test_world_airframes
        assert all(e == {} for e in _effects_by_model(plan)["mini2"])
        for model in ("inspire2", "matrice300"):
            eff = by[model]
            a0 = pop[model]["asymmetry_db"]
            assert 3.5 <= abs(a0) <= 5.5
            asym = [e["sideband_asymmetry"]["asymmetry_db"] for e in eff if "sideband_asymmetry" in e]
            assert len(asym) >= 0.6 * len(eff)
            assert all(np.sign(a) == np.sign(a0) and abs(a - a0) <= 0.5 + 1e-9 for a in asym)
            assert all(abs(a) >= 3.0 for a in asym)  # catalog: detectable |a| >= 3 dB
            n_eff = np.array([len(e) for e in eff])
            assert (n_eff == 2).mean() >= 0.30 and (n_eff == 0).sum() >= 1 and (n_eff == 1).sum() >= 1
            own = {c for e in eff for c in e if c != "sideband_asymmetry"}
            assert own <= set(PER_FLIGHT) and len(own) >= 2
            for e in eff:
                validate_effects(e)
                assert set(e) <= set(CAUSES)
                if "motor_log_lag" in e:
                    assert 0.3 <= abs(e["motor_log_lag"]["lag_s"]) <= 0.7
                if "motor_speed_scale" in e:
                    assert 0.05 <= abs(e["motor_speed_scale"]["scale"] - 1) <= 0.10 + 1e-9
                if "sideband_fading" in e:
                    assert 3 <= e["sideband_fading"]["fading_std_db"] <= 6
                    assert 1 <= e["sideband_fading"]["timescale_s"] <= 2
                if "body_fluctuation" in e:
                    assert 3 <= e["body_fluctuation"]["body_std_db"] <= 6
                    assert 0.15 <= e["body_fluctuation"].get("timescale_s", 0.3) <= 1.0
    # the seed decides: the per-model values and the flights that carry effects change
    a, b = plan_world(profile, 11), plan_world(profile, 12)
    assert world_population(11) != world_population(12)
    assert [s.effects for s in a] != [s.effects for s in b]
    # both signs occur over worlds (the sign is drawn, not fixed)
    signs = {np.sign(world_population(s)[m]["asymmetry_db"]) for s in range(10) for m in ("inspire2", "matrice300")}
    assert signs == {-1.0, 1.0}


def test_world_key_records_effects_and_population(tmp_path):
    """The key of a default-profile world (two flights emulated) lists every flight's
    effects, which of them are systematic, and the per-model systematic values."""
    from microdoppler.emulator.profiles import world_population

    from microdoppler.emulator.profiles import world_airframes

    plan = plan_world("default", 11)
    two = [
        s for s in plan if s.drone_model == "inspire2" and len(s.effects) == 2 and "blade_imbalance" not in s.effects
    ][:1]
    two += [s for s in plan if s.drone_model == "matrice300" and not s.effects][:1]
    two += [s for s in plan if "blade_imbalance" in s.effects][:1]  # an imbalanced airframe's flight
    assert len(two) == 3
    two = [replace(s, duration_s=2.0) for s in two]
    key = tmp_path / "key.json"
    emulate_world("default", 11, tmp_path / "w", key_path=key, progress=False, workers=1, specs=two)
    k = json.loads(key.read_text())
    assert k["population"]["systematic"] == json.loads(json.dumps(world_population(11)))
    assert k["population"]["airframes"] == json.loads(json.dumps(world_airframes(11)))
    for s in two:
        entry = k["flights"][s.flight_id]
        assert set(entry["effects"]) == set(s.effects)
        assert entry["systematic"] == (["sideband_asymmetry"] if "sideband_asymmetry" in s.effects else [])
        assert entry["airframe"] == s.airframe and s.airframe.startswith(s.drone_model + "-")
        frame = k["population"]["airframes"][s.drone_model][s.airframe]
        assert entry["airframe_effects"] == list(frame)
        if "blade_imbalance" in s.effects:  # eval_diagnosis-style scoring reads effects.{cause}.{param}
            x = entry["effects"]["blade_imbalance"]["imbalance_db"]
            assert x == frame["blade_imbalance"]["imbalance_db"] and 3.0 <= x <= 10.0
            amps = entry["truth"]["blade_amplitudes"]
            assert len(amps) == 2 and abs(sum(amps) - 2) < 1e-9
            assert abs(20 * np.log10(min(amps) / max(amps)) + x) < 1e-9
        else:
            assert entry["truth"]["blade_amplitudes"] is None


@pytest.mark.parametrize("profile", ["default", "paper"])
def test_world_airframes(profile):
    """Every drone flight is flown by one of its model's airframes, each airframe flies
    about as many flights; of each large model's airframes about a third (at least one)
    carry one unequal blade, 3-10 dB, on every flight they fly and on no other; Minis
    never. The airframes leave the other effects and every other draw as they were."""
    from microdoppler.emulator.profiles import (
        AIRFRAMES_PER_MODEL,
        EFFECT_MODELS,
        IMBALANCE_DB,
        plan_effects,
        world_airframes,
    )

    for seed in (11, 20261121, 5):
        plan = plan_world(profile, seed)
        frames = world_airframes(seed)
        assert frames == world_airframes(seed)
        for model, fr in frames.items():
            assert len(fr) == AIRFRAMES_PER_MODEL
            flights = [s for s in plan if s.drone_model == model]
            counts = [sum(s.airframe == a for s in flights) for a in fr]
            assert sum(counts) == len(flights) and max(counts) - min(counts) <= 1
            imbalanced = [a for a, e in fr.items() if "blade_imbalance" in e]
            if model in EFFECT_MODELS:
                assert len(imbalanced) == 1
                for a in imbalanced:
                    assert IMBALANCE_DB[0] <= fr[a]["blade_imbalance"]["imbalance_db"] <= IMBALANCE_DB[1]
            else:
                assert not imbalanced
            for s in flights:
                assert s.effects.get("blade_imbalance") == fr[s.airframe].get("blade_imbalance")
        assert all(s.airframe == "" and "blade_imbalance" not in s.effects for s in plan if s.target == "bird")
        # the flights' own effects are plan_effects' (airframes come from streams of their own)
        own = plan_effects([s.drone_model if s.target == "drone" else "" for s in plan], seed)
        assert [{c: p for c, p in s.effects.items() if c != "blade_imbalance"} for s in plan] == own
    # the default world has imbalanced flights of both large models; values differ by seed
    plan = plan_world(profile, 20261121)
    for model in EFFECT_MODELS:
        assert any("blade_imbalance" in s.effects for s in plan if s.drone_model == model)
    assert world_airframes(11) != world_airframes(12)


def _taper_line_power(blade_length_m, wavelength_m, k_max):
    """One tapered blade's own power per rotation harmonic (the emulator's nested
    wires, BLADE_TAPER), from its pattern over one revolution."""
    from microdoppler.emulator.world import BLADE_TAPER
    from microdoppler.synthesis.model import BladeModel

    n = 1 << 14
    g = sum(
        BladeModel(1, blade_length_m * fr, wavelength_m, table_size=n).table().astype(np.complex128)
        for fr in BLADE_TAPER
    )
    return np.abs(np.fft.fft(g) / n)[: k_max + 1] ** 2


def _nonmultiple_db(flight, line_power=None):
    """The non-multiple rotation lines relative to the blade-passing ones (Table VI's
    nonmultiple_db) over the whole flight, with the flight's own log; ``line_power``
    one blade's own line powers (default the thin wire of eq. 1)."""
    from scipy.signal.windows import blackmanharris

    from microdoppler.datasets.fidelity import FidelityConfig, cpi_features, nonmultiple_db
    from microdoppler.diagnosis.measure import thin_wire_line_power

    cfg, sc = FidelityConfig(nonmultiple_min_cpis=4), SpectrogramConfig()  # a 16 s flight: ~56 CPIs in all
    sp = spectrogram(flight.iq, flight.prf_hz, sc)
    body = _body_doppler(flight, sp)
    rev = (
        np.column_stack(
            [
                np.interp(sp.time_s, flight.motors_time_s, flight.motors_rpm[:, m])
                for m in range(flight.motors_rpm.shape[1])
            ]
        )
        / 60.0
    )
    L, lam = float(flight.attrs["blade_length_m"]), flight.wavelength_m
    lp = line_power(L, lam, cfg.rotation_orders) if line_power else thin_wire_line_power(L, lam, cfg.rotation_orders)
    f = cpi_features(
        sp,
        body,
        rev.mean(1),
        n_blades=int(flight.attrs["n_blades"]),
        highpass_hz=sc.highpass_hz,
        cfg=cfg,
        motor_rev_s=rev,
        line_power=lp,
        window=blackmanharris(sc.n_fft, sym=False),
    )
    return nonmultiple_db(f, np.ones(len(sp.time_s), bool), cfg)


@pytest.mark.slow
def test_imbalanced_airframes_make_odd_rotation_lines(rng):
    """An imbalanced airframe of the default world (one blade of every rotor
    10^(-x/20) of the other): the odd rotation-rate lines stand ((1 - a) / (1 + a))^2
    below the even (blade-passing) ones, relative to the tapered blade's own line
    powers; the same flight with equal blades has none (below -25 dB), and the
    blade-passing lines keep their level (amplitudes sum to the blade count)."""
    from microdoppler.emulator.profiles import world_airframes

    frames = world_airframes(20261121)
    for model in ("inspire2", "matrice300"):
        x = [e["blade_imbalance"]["imbalance_db"] for e in frames[model].values() if e][0]
        spec = _drone(
            rng,
            model,
            duration_s=16.0,
            snr_db=50.0,
            path="straight",
            first_sideband_db=8.0,
            harmonic_falloff_db=5.0,
            effects={"blade_imbalance": {"imbalance_db": x}},
        )
        f, tr = emulate_flight(spec)
        a = 10 ** (-x / 20)
        want = 20 * np.log10((1 - a) / (1 + a))
        got = _nonmultiple_db(f, _taper_line_power)
        assert abs(got - want) < 1.0, (model, x, got, want)
        f0, _ = emulate_flight(replace(spec, effects={}))
        assert _nonmultiple_db(f0, _taper_line_power) < -25.0
        body0, sb0, _ = _sideband_levels(f0, tr, n_harm=1)
        body1, sb1, _ = _sideband_levels(f, tr, n_harm=1)
        assert abs(np.median(sb1[0] - body1) - np.median(sb0[0] - body0)) < 1.0


def test_motor_model_calibrated_against_real_log(capsys, ulog_path):
    """Emulated motors differ and fluctuate like the real PX4 log's (same rate, relative
    units): every statistic within a factor 2.5 of the real one. The log comes from the
    ``ulog_path`` fixture (conftest), which fails, not skips, when ../shared is missing."""
    from microdoppler.emulator.calibration import METRICS, compare_with_real

    df = compare_with_real(ulog_path, n_flights=4, seed=3)
    assert "real" in capsys.readouterr().out
    assert list(df.metric) == list(METRICS)
    for _, r in df.iterrows():
        assert 0.4 <= r.ratio <= 2.5, (r.metric, r.real, r.emulated_mean)


def test_calibration_default_log_is_the_shared_one(ulog_path):
    """``python -m microdoppler.emulator.calibration`` without an argument reads the
    real log from ../shared beside the repository (it once looked one level too high)."""
    from microdoppler.emulator.calibration import DEFAULT_ULOG

    assert DEFAULT_ULOG.resolve() == ulog_path.resolve()


def test_motor_stats_detect_spread(rng):
    from microdoppler.emulator.calibration import motor_stats

    t = np.arange(0, 60, 0.05)
    base = 80 * (1 + 0.02 * np.sin(2 * np.pi * 0.1 * t))
    even = np.column_stack([base] * 4) + rng.normal(0, 0.1, (len(t), 4))
    spread = even * np.array([0.9, 1.0, 1.05, 1.05])
    assert motor_stats(t, even)["spread_rel"] < 0.005
    assert abs(motor_stats(t, spread)["spread_rel"] - np.std([0.9, 1.0, 1.05, 1.05]) / 1.0) < 0.01


@pytest.mark.slow
def test_class_mean_snr_matches_table_iii():
    """Per-class mean SNR of the paper profile within 3 dB of Table III: the SNR model's
    nominal value over every planned flight minus the nominal-to-measured loss measured
    with the pipeline's chain on a seeded subsample of emulated flights (8 s each)."""
    from microdoppler.emulator.calibration import snr_check

    df = snr_check("paper", 20261121, n_per_class=32, duration_cap_s=8.0, sample_seed=2, printout=False)
    for _, r in df.iterrows():
        assert abs(r.predicted_mean_db - r.table_iii_db) <= 3.0, r.to_dict()


def _line_power_std(flight, offset_k: int):
    """Std over timesteps of the body (k=0) or first upper sideband (k=1) line power [dB]."""
    sp = spectrogram(flight.iq, flight.prf_hz, FULL)
    fb = _body_doppler(flight, sp)
    spacing = 2 * np.interp(sp.time_s, flight.motors_time_s, flight.motors_rpm.mean(1)) / 60.0
    w = 6.0 if offset_k == 0 else 14.0
    return float(np.std(line_snr_db(sp, fb + offset_k * spacing, search_hz=w)))


@pytest.mark.slow
def test_fading_and_body_fluctuation_knobs(rng):
    # a straight leg keeps the body out of the clutter notch, whose passages would
    # otherwise dominate the body line's spread
    spec = _drone(rng, "inspire2", duration_s=30.0, snr_db=45.0, speed_mps=6.0, path="straight")
    f0, _ = emulate_flight(spec)
    ff, tf = emulate_flight(replace(spec, effects={"sideband_fading": {"fading_std_db": 6.0, "timescale_s": 1.5}}))
    fb, _ = emulate_flight(replace(spec, effects={"body_fluctuation": {"body_std_db": 6.0}}))
    assert tf["effects"]["sideband_fading"] == {"fading_std_db": 6.0, "timescale_s": 1.5}
    # fading: the sideband fluctuates more, the body does not
    assert _line_power_std(ff, 1) > _line_power_std(f0, 1) + 1.5
    assert abs(_line_power_std(ff, 0) - _line_power_std(f0, 0)) < 1.0
    # body fluctuation: the body line fluctuates more
    assert _line_power_std(fb, 0) > _line_power_std(f0, 0) + 1.5


@pytest.mark.slow
def test_radar2_has_occasional_artifacts(rng):
    n = {"radar1": 0, "radar2": 0}
    for rid in n:
        for _ in range(4):
            _, tr = emulate_flight(_drone(rng, "mini2", radar_id=rid, duration_s=30.0))
            n[rid] += tr["artifacts"]
    assert n["radar1"] == 0 and n["radar2"] >= 1


def test_straight_path_keeps_body_out_of_the_notch(rng):
    """A diagnosis-style flight: 40 s Inspire, straight leg, one effect, body SNR >= 36 dB."""
    spec = FlightSpec(
        "s",
        "drone",
        drone_model="inspire2",
        duration_s=40.0,
        mean_range_m=1500.0,
        speed_mps=8.0,
        seed=int(rng.integers(2**31)),
        snr_db=44.0,
        path="straight",
        direction=-1,
        effects={"motor_log_lag": {"lag_s": 0.4}},
        with_background=False,
    )
    f, tr = emulate_flight(spec)
    sp = spectrogram(f.iq, f.prf_hz)
    fb = _body_doppler(f, sp)
    assert np.all(fb > 30)  # approaching: positive Doppler, far from the 15 Hz notch
    assert np.mean(line_snr_db(sp, fb)) >= 36.0
    assert list(tr["effects"]) == ["motor_log_lag"]


def test_gliding_birds_show_a_bare_body_line():
    """World v3d: gliding species glide for their drawn share of the time, and while a
    bird glides its echo is a bare body line (no wing Doppler swing, no wingbeat
    sidebands), while flapping spreads power 6-60 Hz around it."""
    from dataclasses import replace

    from microdoppler.emulator.bird import GLIDE_SHARE, GLIDE_TIME_S, SPECIES, plan_group, render

    shares, drawn = [], []
    for k in range(40):
        g = plan_group(
            "single",
            600.0,
            mean_range_m=1000.0,
            height_m=60.0,
            speed_mps=12.0,
            rng=np.random.default_rng([k, 1]),
            manoeuvre_rng=np.random.default_rng([k, 8]),
        )
        if not SPECIES[g.species].glides:
            assert g.glide_share == 0.0 and np.all(g.flapping == 1.0)
            continue
        assert GLIDE_SHARE[0] <= g.glide_share <= GLIDE_SHARE[1]
        assert GLIDE_TIME_S[0] <= g.glide_time_s <= GLIDE_TIME_S[1]
        drawn.append(g.glide_share)
        shares.append(float(np.mean(g.flapping[:, 0] < 0.5)))
    assert len(drawn) >= 15
    err = np.abs(np.array(shares) - np.array(drawn))
    assert np.median(err) < 0.1 and np.corrcoef(shares, drawn)[0, 1] > 0.6, (shares, drawn)

    prf, lam = 2000.0, 0.23
    g = plan_group("single", 10.0, mean_range_m=1000.0, height_m=60.0, speed_mps=12.0, rng=np.random.default_rng(7))
    g = replace(g, wing_rel=np.array([10 ** (-8 / 20)]))  # loud wings: the test's contrast

    def off_body_share(flap_level):
        h = replace(g, flapping=np.full_like(g.flapping, flap_level))
        x = render(h, int(8 * prf), prf, lam, 1.0, np.random.default_rng(3))
        # remove the body's Doppler (from the plan's own range) before the spectrum
        t = np.arange(len(x)) / prf
        x = x * np.exp(1j * 4 * np.pi / lam * np.interp(t, h.t_s, h.range_m[:, 0]))
        p = np.abs(np.fft.fftshift(np.fft.fft(x * np.hanning(len(x))))) ** 2
        f = np.fft.fftshift(np.fft.fftfreq(len(x), 1 / prf))
        band = (np.abs(f) > 6) & (np.abs(f) < 60)
        return p[band].sum() / p.sum()

    glide, flap = off_body_share(0.0), off_body_share(1.0)
    assert glide < 0.01 and flap > 50 * glide, (glide, flap)
