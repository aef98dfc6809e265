"""The rotor comb's harmonic order (microdoppler.rotors.order) on recordings the project
did not shape: tests/any_radar.py writes them from point scatterers along each blade and
shares no code with the emulator or the synthesis model.

Each recording is scored against its truth (the true speeds averaged over each CPI with
the window's power profile): the mean rotor speed within 2 %, or the order marked
ambiguous with the truth among the alternatives; never more than 10 % off unless marked.
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pytest
from scipy.special import jv

from any_radar import draw_case, make_recording, rotor_line_spacing_hz, true_cpi_means
from microdoppler.rotors.order import _tail_fall_db, ambiguity_line, order_attrs, rho_max
from microdoppler.rotors.speed import estimate_rotor_speeds, thin_wire_harmonic


def score(est, truth, flight):
    """(median relative error of the mean rotor speed, the speeds the estimate names:
    the chosen one and the alternatives [rev/s], the true mean [rev/s])."""
    assert est.ok, est.reason
    v = est.valid
    tm = true_cpi_means(truth, est.time_s, est.n_fft, flight.prf_hz).mean(axis=1)
    err = float(np.median(est.common_rev_s[v] / tm[v] - 1))
    o = est.info["order"]
    return err, [float(np.median(est.common_rev_s[v]))] + list(o["alternatives_rev_s"]), float(np.median(tm[v]))


def assert_honest(est, truth, flight):
    """Within 2 %, or ambiguous with the truth (3 %) among the named speeds; never more
    than 10 % off unless ambiguous."""
    err, named, true_mean = score(est, truth, flight)
    amb = est.info["order"]["ambiguous"]
    if abs(err) > 0.02:
        assert amb, f"{flight.flight_id}: {100 * err:+.1f} % off and not marked ambiguous"
        assert any(abs(s / true_mean - 1) <= 0.03 for s in named), (
            f"{flight.flight_id}: ambiguous, but the truth {true_mean:.1f} rev/s is not among {named}"
        )
    return err, amb


def assert_within_and_covered(est, truth, flight, rel=0.02, share=0.8):
    """Within ``rel`` of the truth (and honest), and at least ``share`` of the CPIs'
    errors within 2 reported sigma."""
    err, _ = assert_honest(est, truth, flight)
    assert abs(err) <= rel
    v = est.valid
    tm = true_cpi_means(truth, est.time_s, est.n_fft, flight.prf_hz).mean(axis=1)
    z = (est.common_rev_s[v] - tm[v]) / est.common_std_rev_s[v]
    assert np.mean(np.abs(z) <= 2) >= share


# ------------------------------------------------------------------ physics of the pieces


def test_rho_max_is_the_blade_sum_of_one_weak_blade():
    """The rotation-rate family's largest level relative to the blade-passing family:
    the k-th Fourier coefficient of the blade sum over the blades (k not a multiple of
    B) against the 0th, for one blade g weaker."""
    for B in (2, 3):
        for weak_db in (3.0, 10.0, 12.0):
            g = 10 ** (-weak_db / 20)
            a = np.ones(B)
            a[0] = g
            c = np.abs(np.fft.fft(a))  # coefficient k: sum_b a_b exp(-2 pi j k b / B)
            assert np.isclose(rho_max(B, weak_db), c[1] / c[0], rtol=1e-12)


def test_generator_lines_follow_the_blades():
    """The generator's physics: equal blades put lines at multiples of B f only, one
    weak blade adds lines at the other multiples of f, and the blade energy ends at the
    tips' Doppler 2 (2 pi f L) / lambda times cos(elevation)."""
    base = dict(
        carrier_hz=1.3e9,
        prf_hz=6000.0,
        n_rotors=4,
        n_blades=2,
        blade_length_m=0.2,
        tip_speed_mps=90.0,
        setup="hover",
        elevation_deg=0.0,
        body_snr_db=40.0,
        blade_to_body_db=0.0,
    )
    for weak in (0.0, 6.0):
        case = draw_case(3, duration_s=2.0, weak_blade_db=weak, **base)
        _, truth = make_recording(case, with_parts=True)
        spacing, extent = rotor_line_spacing_hz(
            truth["blades"], case.prf_hz, float(truth["rev_s"].mean()), floor_db=20.0
        )
        f = float(truth["rev_s"].mean())
        assert np.isclose(spacing, (1 if weak else 2) * f, rtol=0.03)
        assert np.isclose(extent, 2 * case.tip_speed_mps / case.wavelength_m, rtol=0.12)


def _whole_signal_pair_db(blades, case, rev_s):
    """The weaker side's peak within 3 % of +-B f in the whole noise-free blade signal's
    mean periodogram [dB over the noise per bin]: every line there, whatever its order."""
    from scipy.signal.windows import blackmanharris

    w = blackmanharris(4096, sym=False)
    starts = np.arange(0, len(blades) - 4096 + 1, 2048)[:8]
    p = np.mean([np.abs(np.fft.fft(blades[s : s + 4096] * w)) ** 2 for s in starts], axis=0) / (w**2).sum()
    f = np.fft.fftfreq(4096, 1 / case.prf_hz)
    fb = case.n_blades * rev_s
    return min(10 * np.log10(p[np.abs(f - sgn * fb) <= 0.03 * fb + 2 * case.prf_hz / 4096].max()) for sgn in (1, -1))


@pytest.mark.parametrize("seed", [1003, 1070])
def test_generator_visibility_reads_the_first_pair_alone(seed):
    """The generator's visibility rule measures the first blade-passing pair itself.
    At 1.3 GHz (seed 1003) the blade flash holds few orders, the pair is the line near
    +-B f and both readings agree; at 24 GHz (seed 1070: six rotors, the flash folded
    over the band about four times) other orders and other rotors' lines fold next to
    +-B f and stand >= 10 dB over a first pair that is not visible."""
    case = draw_case(seed, duration_s=6.0)
    _, truth = make_recording(case, with_parts=True)
    whole = _whole_signal_pair_db(truth["blades"], case, float(truth["rev_s"].mean()))
    if case.carrier_hz < 2e9:
        assert truth["visible"] and abs(truth["first_pair_db"] - whole) < 0.5
    else:
        assert whole - truth["first_pair_db"] >= 10.0 and whole >= 10.0
        assert not truth["visible"]


# ------------------------------------------------------------------ the cases


@pytest.mark.slow
@pytest.mark.parametrize("seed, weak_db, n_blades", [(11, 6.0, 2), (13, 8.0, 3)])
def test_unequal_blades_give_the_rotation_rate(seed, weak_db, n_blades):
    """A rotor with one weak blade returns lines at every multiple of its rotation rate;
    the lines alone read them as a blade-passing comb at 1/B of it (the issue's 0.5x on
    every recording); with the order check the speed is right."""
    case = draw_case(
        seed,
        duration_s=4.0,
        carrier_hz=1.3e9,
        prf_hz=5000.0,
        n_rotors=4,
        n_blades=n_blades,
        blade_length_m=0.2,
        tip_speed_mps=88.0,
        setup="hover",
        weak_blade_db=weak_db,
        blade_to_body_db=0.0,
        body_snr_db=40.0,
        elevation_deg=5.0,
    )
    flight, truth = make_recording(case)
    raw = estimate_rotor_speeds(flight, order=False)
    tm = true_cpi_means(truth, raw.time_s, raw.n_fft, flight.prf_hz).mean(axis=1)
    assert np.isclose(np.nanmedian(raw.common_rev_s / tm), 1 / n_blades, rtol=0.03)  # the failure exists
    est = estimate_rotor_speeds(flight)
    err, amb = assert_honest(est, truth, flight)
    assert abs(err) <= 0.02 and not amb
    assert est.info["order"]["ratio_to_lines"] == pytest.approx(n_blades, rel=1e-3)


@pytest.mark.slow
@pytest.mark.parametrize(
    "geometry",
    [
        dict(
            carrier_hz=5.8e9,
            prf_hz=13802.07,
            n_rotors=4,
            n_blades=2,
            blade_length_m=0.21825,
            tip_speed_mps=60.215,
            setup="flying",
            weak_blade_db=0.0,
            body_snr_db=41.77,
            blade_to_body_db=4.94,
            elevation_deg=19.09,
            radial_speed_mps=-11.10,
            clutter_db=51.58,
        ),
        dict(
            carrier_hz=3.3e9,
            prf_hz=19359.23,
            n_rotors=6,
            n_blades=3,
            blade_length_m=0.24303,
            tip_speed_mps=63.09,
            setup="flying",
            weak_blade_db=6.48,
            body_snr_db=41.05,
            blade_to_body_db=-3.13,
            elevation_deg=20.34,
            radial_speed_mps=-2.34,
            clutter_db=42.73,
        ),
    ],
)
def test_default_cpi_is_the_papers_in_time_at_a_high_prf(geometry):
    """At 14-19 kHz a CPI of the paper's 4096 pulses lasts 0.2-0.3 s: a bin is 4 % of
    the first blade-passing line of slow (44 rev/s) rotors, and the mean was 2.3-2.8 %
    off (the benchmark's any1039 and any5063 geometries; on the first, seed 61's
    rotors read at twice their speed without a doubt). The default CPI is the paper's
    0.56 s in time (8192 pulses here): within 2 %, not ambiguous, and the speeds
    within 2 sigma (rotor speeds, blades and phases drawn from seed 61)."""
    case = draw_case(61, duration_s=6.0, **geometry)
    flight, truth = make_recording(case)
    est = estimate_rotor_speeds(flight)
    assert est.n_fft == 8192
    err, amb = assert_honest(est, truth, flight)
    assert abs(err) <= 0.02 and not amb
    v = est.valid
    tm = true_cpi_means(truth, est.time_s, est.n_fft, flight.prf_hz).mean(axis=1)
    assert np.mean(np.abs(est.common_rev_s[v] - tm[v]) <= 2 * est.common_std_rev_s[v]) >= 0.8


@pytest.mark.slow
def test_default_cpi_falls_back_to_4096_pulses_where_the_lines_smear():
    """1.3 GHz, 19 kHz PRF, a flying quadcopter of three-blade rotors whose speeds wobble:
    over the default CPI (8192 pulses, 0.43 s) each line smears into ripples without a
    prominent peak and no CPI shows a pair (the benchmark's any1025 geometry; rotor
    speeds, blades and phases from seed 62). The paper's 4096 pulses show them: the
    estimate is made there and says so."""
    geometry = dict(
        carrier_hz=1.3e9,
        prf_hz=19062.67,
        n_rotors=4,
        n_blades=3,
        blade_length_m=0.14579,
        tip_speed_mps=93.49,
        setup="flying",
        weak_blade_db=4.60,
        body_snr_db=42.03,
        blade_to_body_db=1.40,
        elevation_deg=16.24,
        radial_speed_mps=-10.18,
        clutter_db=35.20,
    )
    flight, truth = make_recording(draw_case(62, duration_s=6.0, **geometry))
    assert not estimate_rotor_speeds(flight, n_fft=8192).ok
    est = estimate_rotor_speeds(flight)
    assert est.n_fft == 4096 and "8192" in est.info["cpi"] and "CPI 4096 pulses" in est.summary()
    err, amb = assert_honest(est, truth, flight)
    assert abs(err) <= 0.02 and not amb


def test_default_cpi_lasts_the_papers_cpi_and_at_least_4096_pulses():
    """The default CPI: the power of two nearest 0.56 s x PRF, never under 4096 pulses
    (shorter CPIs at low PRF read an unequal blade's comb 12.6 % off)."""
    from microdoppler.io.flightzarr import Flight

    for prf, n in ((2000.0, 4096), (7300.0, 4096), (10000.0, 4096), (11000.0, 8192), (19000.0, 8192), (25000.0, 16384)):
        fl = Flight(
            attrs={
                "schema": "flight-zarr/1",
                "flight_id": "noise",
                "target": "drone",
                "radar_id": "r",
                "prf_hz": prf,
                "carrier_hz": 3e9,
                "n_motors": 4,
                "n_blades": 2,
            },
            iq=np.zeros(100, np.complex64),
            track_time_s=np.array([0.0, 1.0]),
            track_range_m=np.array([100.0, 100.0]),
            track_radial_velocity_mps=np.zeros(2),
        )
        assert estimate_rotor_speeds(fl).n_fft == n


@pytest.mark.slow
def test_equal_blades_on_a_stand():
    """The issue's stand: 3.3 GHz CW sampled at 5 kHz, four equal two-blade rotors near
    160 rev/s on a stand (body at 0 Hz), the signature reaching +-1.7 kHz."""
    case = draw_case(
        12,
        duration_s=4.0,
        carrier_hz=3.3e9,
        prf_hz=5000.0,
        n_rotors=4,
        n_blades=2,
        blade_length_m=0.08,
        tip_speed_mps=80.0,
        setup="hover",
        weak_blade_db=0.0,
        blade_to_body_db=0.0,
        body_snr_db=40.0,
        elevation_deg=5.0,
    )
    flight, truth = make_recording(case)
    assert 150 <= truth["rev_s"].mean() <= 171
    assert_honest(estimate_rotor_speeds(flight), truth, flight)


@pytest.mark.slow
def test_lone_pair_is_the_comb_where_the_blades_allow_no_other():
    """A small three-blade drone in L band (0.06 m blades, ~160 rev/s at 1.3 GHz): the
    blade flash's Doppler extent (beta = 4 pi L / lambda ~3.3 rotation rates) holds the
    first blade-passing harmonic only, so every CPI shows one sideband pair and no comb.
    It was refused ("no HERM comb", issue 33's any1036); the pair is the comb, and the
    speed within 2 %, with ``info["lone_pair"]`` saying why. With a declared blade
    length that would show a comb (0.25 m: beta ~14) the same lone pair is still no
    estimate (clutter or birds)."""
    from dataclasses import replace

    case = draw_case(
        41,
        duration_s=4.0,
        carrier_hz=1.3e9,
        prf_hz=6000.0,
        n_rotors=4,
        n_blades=3,
        blade_length_m=0.06,
        tip_speed_mps=60.0,
        setup="hover",
        weak_blade_db=0.0,
        body_snr_db=40.0,
    )
    flight, truth = make_recording(case)
    est = estimate_rotor_speeds(flight)
    assert est.info["n_cpi_comb"] == 0 and "lone_pair" in est.info, est.info
    err, amb = assert_honest(est, truth, flight)
    assert abs(err) <= 0.02 and not amb, (err, est.info["order"])
    longer = replace(flight, attrs={**flight.attrs, "blade_length_m": 0.25})
    est = estimate_rotor_speeds(longer, order=False)
    assert not est.ok and est.reason.startswith("no HERM comb"), est.reason


@pytest.mark.slow
def test_a_lone_pair_must_persist():
    """A lone pair is read as the comb only where it stands in half the CPIs at least: a
    rotor's first pair shows in most CPIs, an intermittent pair (an emulated Mini's, 14
    of 70 CPIs at the speed range's floor) is not its comb. The small L-band drone of
    the test above for 40 % of a 10 s recording, the same scene with its blades 60 dB
    down for the rest: no estimate; the drone for 80 % of it: the speed within 2 %."""
    from dataclasses import replace

    base = dict(
        duration_s=10.0,
        carrier_hz=1.3e9,
        prf_hz=6000.0,
        n_rotors=4,
        n_blades=3,
        blade_length_m=0.06,
        tip_speed_mps=60.0,
        setup="hover",
        weak_blade_db=0.0,
        body_snr_db=40.0,
    )
    flight, truth = make_recording(draw_case(41, **base))
    quiet, _ = make_recording(draw_case(41, **base, blade_to_body_db=-60.0))
    for share, ok in ((0.4, False), (0.8, True)):
        k = int(share * len(flight.iq))
        mixed = replace(flight, iq=np.concatenate([np.asarray(flight.iq)[:k], np.asarray(quiet.iq)[k:]]))
        est = estimate_rotor_speeds(mixed)
        assert est.ok == ok, (share, est.reason, est.info.get("n_cpi_estimated"), len(est.time_s))
        if ok:
            v = est.valid
            tm = true_cpi_means(truth, est.time_s, est.n_fft, flight.prf_hz).mean(axis=1)
            assert abs(np.median(est.common_rev_s[v] / tm[v] - 1)) <= 0.02
        else:
            assert est.reason.startswith("no HERM comb") and 3 <= est.info["n_cpi_estimated"] < 0.5 * len(est.time_s)


def test_thin_wire_harmonics_are_a_simulated_blades():
    """A blade of 400 scatterers spread evenly from hub to tip, its tip's phase swinging
    by +-x over one revolution (B blades at 2 pi / B): the slow-time signal's Fourier
    coefficients at B and 2 B agree with :func:`thin_wire_harmonic` within 0.2 dB, and
    the second harmonic falls far below the first where the blade is short against the
    wavelength (x = 3: -18 dB for two blades, -35 dB for three) and stays within a few
    dB of it where it is long (x = 12)."""
    n_t, n_r = 2048, 400
    theta = 2 * np.pi * np.arange(n_t) / n_t
    r = (np.arange(n_r) + 0.5) / n_r
    for B in (2, 3):
        rel = []
        for x in (3.0, 6.0, 12.0):
            sig = (
                sum(
                    np.exp(1j * x * r[None, :] * np.sin(theta[:, None] + 2 * np.pi * b / B)).mean(axis=1)
                    for b in range(B)
                )
                / B
            )
            c = np.abs(np.fft.fft(sig) / n_t)
            for k in (B, 2 * B):
                model = abs(float(thin_wire_harmonic(k, x)[0]))
                assert abs(20 * np.log10(c[k] / model)) < 0.2, (B, x, k, c[k], model)
            rel.append(20 * np.log10(c[2 * B] / c[B]))
        assert rel[0] < -15 and rel[0] < min(rel[1:]) and rel[2] > -6, (B, rel)


# the geometry of the fifth hold-out's any13021 (1.3 GHz, 2.6 kHz, a flying eight-rotor
# drone of 0.069 m two-blade rotors at 200 rev/s): beta = 3.8, so the blade flash
# (1.1 beta f at most) just reaches the second blade-passing harmonic (4 f) and the
# extent rule does not hold; the thin wire puts that harmonic >= 11 dB under the first
ANY13021 = {k: v for k, v in asdict(draw_case(13021, duration_s=6.0)).items() if k not in ("name", "seed")}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [13021, 71])
def test_lone_pair_is_the_comb_where_the_second_order_is_too_weak(seed):
    """any13021 showed its first blade-passing pair in 6 of 6 CPIs and no second order:
    "no HERM comb" though its lines are visible. The thin-wire blade puts the second
    harmonic at most -11 dB from the first (kappa up to 1.1), under the pair threshold
    at the first pair's level: the lone pair is the comb (``info["lone_pair"]`` says
    so) and the speed within 2 % or honestly ambiguous; with ``lone_level=False`` no
    estimate (the recording, and its geometry drawn with seed 71)."""
    from microdoppler.rotors.speed import RotorSpeedConfig

    flight, truth = make_recording(draw_case(seed, **ANY13021))
    assert truth["visible"]
    est = estimate_rotor_speeds(flight)
    assert est.ok and "thin-wire" in est.info["lone_pair"], (est.reason, est.info.get("lone_pair"))
    assert_honest(est, truth, flight)
    old = estimate_rotor_speeds(flight, config=RotorSpeedConfig(lone_level=False), order=False)
    assert not old.ok and old.reason.startswith("no HERM comb"), old.reason


@pytest.mark.slow
def test_second_order_absence_is_the_lines_chance_over_the_extent():
    """``second_order_absence_p`` against a count of simulated CPIs: per CPI the second
    pair's two lines, each its thin-wire level (kappa drawn from the 11 points of
    ``extent_range``) over unit complex Gaussian noise, both >= the threshold or not;
    the share of recordings showing it in at most n_seen of n CPIs (20,000 recordings,
    within 0.015). And what a radar researcher expects of it: the higher the first pair,
    the less probable a missing second order; blades long for the wavelength (a strong
    second harmonic) make it improbable, short ones certain."""
    from types import SimpleNamespace

    from microdoppler.rotors.order import OrderConfig
    from microdoppler.rotors.speed import second_order_absence_p

    rng = np.random.default_rng(5)
    lam = 0.0909  # 3.3 GHz
    for L, B, first_db, n_seen, n in (
        (0.04, 2, 16.0, 0, 7),
        (0.05, 3, 20.0, 1, 10),
        (0.03, 2, 26.0, 0, 5),
        (0.06, 3, 14.0, 0, 6),
    ):
        fl = SimpleNamespace(attrs={"blade_length_m": L}, wavelength_m=lam)
        p = second_order_absence_p(fl, B, first_db, n_seen, n, 10.0)
        lo, hi = OrderConfig().extent_range
        kap = rng.choice(np.linspace(lo, hi, 11), 20000)
        x = kap * 4 * np.pi * L / lam
        amp = 10 ** (first_db / 20) * np.abs(thin_wire_harmonic(2 * B, x) / thin_wire_harmonic(B, x))
        noise = (rng.standard_normal((20000, n, 2)) + 1j * rng.standard_normal((20000, n, 2))) / np.sqrt(2)
        seen = (np.abs(amp[:, None, None] + noise) ** 2 >= 10.0).all(axis=2).sum(axis=1)
        assert 0.02 < p < 0.98 and abs(p - np.mean(seen <= n_seen)) <= 0.015, (L, B, p, np.mean(seen <= n_seen))
    fl = SimpleNamespace(attrs={"blade_length_m": 0.05}, wavelength_m=lam)
    ps = [second_order_absence_p(fl, 2, db, 0, 8, 10.0) for db in (12.0, 18.0, 24.0, 30.0)]
    assert all(a > b for a, b in zip(ps, ps[1:])), ps
    assert (
        second_order_absence_p(SimpleNamespace(attrs={"blade_length_m": 0.25}, wavelength_m=lam), 2, 25.0, 0, 8, 10.0)
        < 1e-3
    )
    assert (
        second_order_absence_p(SimpleNamespace(attrs={"blade_length_m": 0.01}, wavelength_m=lam), 2, 25.0, 0, 8, 10.0)
        > 0.999
    )
    assert second_order_absence_p(SimpleNamespace(attrs={}, wavelength_m=lam), 2, 25.0, 0, 8, 10.0) is None


# the sixth hold-out's any15028 (1.3 GHz, 3.0 kHz, a flying six-rotor drone of 0.116 m
# two-blade rotors at 139 rev/s; beta = 6.3) and the fourth's any7019 (0.107 m, three
# blades, 162 rev/s; beta = 5.8): the thin wire's second harmonic is -13 to +2 dB and
# -30 to -10 dB from the first over kappa 0.6-1.1, so at its largest it would pass the
# pair threshold, at most kappas not
ANY15028 = {k: v for k, v in asdict(draw_case(15028, duration_s=6.0)).items() if k not in ("name", "seed")}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [7019, 15028, 72])
def test_lone_pair_is_the_comb_where_its_second_order_would_rarely_show(seed):
    """any7019 (a pair in 12 of 12 CPIs) and any15028 (7 of 7) showed no second order
    and were "no HERM comb" though visible: the largest second harmonic over the
    blade's extent would stand over the pair threshold. Averaged over the extent, a
    second order seen in no CPI is probable (``lone_p_min``): the lone pair is the
    comb, the speed within 2 % or honestly ambiguous; with ``lone_p_min=0`` no estimate
    (the recordings, and any15028's geometry drawn with seed 72)."""
    from microdoppler.rotors.speed import RotorSpeedConfig

    case = draw_case(seed, duration_s=6.0) if seed > 1000 else draw_case(seed, **ANY15028)
    flight, truth = make_recording(case)
    assert truth["visible"]
    est = estimate_rotor_speeds(flight)
    assert est.ok and "with probability" in est.info["lone_pair"], (est.reason, est.info.get("lone_pair"))
    assert_honest(est, truth, flight)
    old = estimate_rotor_speeds(flight, config=RotorSpeedConfig(lone_p_min=0), order=False)
    assert not old.ok and old.reason.startswith("no HERM comb"), old.reason


@pytest.mark.slow
@pytest.mark.parametrize("seed", [43, 44, 45])
def test_lone_pair_is_the_comb_where_the_second_order_folds(seed):
    """A small six-rotor drone at 5.8 GHz seen at 2.95 kHz PRF, flying (body ~+440 Hz):
    the first blade-passing pair (+-~650 Hz) stands inside the band, but the second
    order's far line lies beyond +-0.49 PRF and folds, so no CPI can show two orders as
    mirror pairs. It was refused ("no HERM comb", eval_any_radar's any1029); the lone
    pair is now read as the comb, ``info["lone_pair"]`` says it folds, and the order
    check (whose line model folds) weighs the alternatives: within 2 %, or ambiguous
    with the truth listed (tests/any_radar.py's own echo; draws from the seed)."""
    case = draw_case(
        seed,
        duration_s=4.0,
        carrier_hz=5.8e9,
        prf_hz=2950.0,
        n_rotors=6,
        n_blades=3,
        blade_length_m=0.051,
        tip_speed_mps=72.0,
        setup="flying",
        radial_speed_mps=-11.4,
        weak_blade_db=0.0,
        body_snr_db=36.0,
        blade_to_body_db=4.0,
        elevation_deg=12.0,
    )
    flight, truth = make_recording(case)
    est = estimate_rotor_speeds(flight)
    assert est.ok, est.reason
    assert est.info["n_cpi_comb"] == 0 and "folds" in est.info["lone_pair"], est.info
    assert_honest(est, truth, flight)


@pytest.mark.slow
def test_scaled_lines_put_no_rotor_on_another_orders_line():
    """5.8 GHz, a hovering six-rotor drone of three equal blades whose first pair is
    not visible: the lines read the comb of every second order (twice the speed), the
    order check halves it, and a re-measurement at the chosen rate does not find the
    comb, so the lines' estimate is scaled. Some of the lines' rotors sat on lines of a
    third order (1.5x their neighbours once halved): kept, they moved the mean 16 % off
    with a 0.6 % sigma, not marked ambiguous. A drone's rotors turn within
    ``rotor_spread_max`` of each other: such a rotor goes to the median rotor and the
    change enters sigma (geometry of the benchmark's any5015; the rotors' speeds,
    blades and phases drawn from seed 61)."""
    case = draw_case(
        61,
        duration_s=6.0,
        carrier_hz=5.8e9,
        prf_hz=10793.67,
        n_rotors=6,
        n_blades=3,
        blade_length_m=0.18397,
        tip_speed_mps=90.744,
        setup="hover",
        weak_blade_db=0.0,
        body_snr_db=43.15,
        blade_to_body_db=-5.88,
        elevation_deg=7.9,
        radial_speed_mps=0.0,
        clutter_db=45.63,
    )
    flight, truth = make_recording(case)
    est = estimate_rotor_speeds(flight)
    assert est.info["order"]["remeasured"].startswith("the lines' estimate scaled")
    assert_within_and_covered(est, truth, flight)


# the geometry of the benchmark's hold-out recording any5054 (3.3 GHz, 11.9 kHz PRF, a
# flying six-rotor drone of 0.20 m two-blade rotors, one blade 8.3 dB weak; the rotors
# spread +-8 %), exactly as drawn: rounding its constants to 5 digits turns seed 64 into
# another recording (the lines then read a comb at 1.2x, ambiguous before and after)
ANY5054 = {k: v for k, v in asdict(draw_case(5054, duration_s=6.0)).items() if k not in ("name", "seed")}


@pytest.mark.slow
def test_a_rotor_on_another_familys_line_goes_to_the_median():
    """The order is right (the lines' comb), but in most CPIs one or two rotors sat on
    the others' rotation-rate line k = 3 (an unequal blade's), read as the first
    blade-passing pair of a rotor at 1.5x: the mean was 15 % off, 4 of 16 CPIs within
    2 sigma, not marked ambiguous. A drone's rotors turn within ``rotor_spread_max``
    of their median, whatever the order: such a rotor goes to the median and the change
    into sigma (any5054's geometry; speeds, blades and phases drawn from seed 64)."""
    case = draw_case(64, **ANY5054)
    flight, truth = make_recording(case)
    est = estimate_rotor_speeds(flight)
    o = est.info["order"]
    assert o["ratio_to_lines"] == 1.0 and o["n_rotors_to_median"] > 0
    assert_within_and_covered(est, truth, flight)


@pytest.mark.slow
def test_a_peak_no_line_explains_may_lie_anywhere_in_the_analysed_band():
    """any5054 itself: the lines read the right comb (+4 %), and the order check chose
    0.5x (equal blades at half the speed put lines at the same places) with the true
    order at a relative likelihood of 0.009: -49 %, not marked ambiguous. A peak no line
    explains was charged the density of a peak anywhere within the PRF (11.9 kHz), but
    only peaks inside the analysed band (+-240-420 Hz here, where the rotors' harmonics
    stay apart) are observed: 14-25x too costly, while the half rate's dense windows
    (78 % of the band) explain such peaks by chance. Spread over the analysed band, the
    order is ambiguous and the true order among the alternatives (its comb 3-4 % above
    the mean rotor: the lines follow the median one)."""
    flight, truth = make_recording(draw_case(5054, duration_s=6.0))
    est = estimate_rotor_speeds(flight)
    err, named, true_mean = score(est, truth, flight)
    if abs(err) > 0.02:
        assert est.info["order"]["ambiguous"], f"{100 * err:+.1f} % off and not marked ambiguous"
        assert any(abs(s / true_mean - 1) <= 0.05 for s in named), (named, true_mean)


def test_tail_fall_follows_the_tips_bessel_lines():
    """Beyond k = beta the tip's lines J_k(beta) fall as the Airy function over
    (beta / 2)^(1/3) harmonics: the fall-off a tail window expects is within 1.5 dB of
    20 log10(J_k(beta) / J_beta(beta)) from 4 to 25 dB down, for small and large beta."""
    for beta in (20.0, 200.0, 2000.0):
        width = (beta / 2) ** (1 / 3)
        for m in (0.5, 1.0, 1.5, 2.0):
            k = beta + m * width
            bessel_db = -20 * np.log10(jv(k, beta) / jv(beta, beta))
            model_db = float(_tail_fall_db(np.array([k]), np.array([beta]), np.array([width]))[0])
            assert 3.5 < bessel_db < 26 and abs(model_db - bessel_db) < 1.5, (beta, m, bessel_db, model_db)
    # no fall within kappa f_max
    assert float(_tail_fall_db(np.array([9.0]), np.array([10.0]), np.array([2.0]))[0]) == 0.0


# the geometry of the benchmark's fourth hold-out recording any11007 (1.3 GHz, 3.0 kHz,
# a hovering six-rotor drone of 0.052 m two-blade rotors at 187 rev/s, one blade 6.8 dB
# weak): beta = 4 pi L / lambda = 2.8, so the tail the order check allows beyond the
# tips' Doppler (tail_harmonics beta^(1/3) harmonics) is as wide as the tips' Doppler
ANY11007 = {k: v for k, v in asdict(draw_case(11007, duration_s=6.0)).items() if k not in ("name", "seed")}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [11007, 67])
def test_a_tail_window_without_a_line_costs_what_the_tip_allows(seed):
    """any11007: the lines read the rotation-rate line (an unequal blade's) as the
    blade-passing one, 0.5x, and the order check kept it 35 log-units ahead of the true
    order: -50 %, not marked ambiguous. The true order paid for its tail windows beyond
    its tips' Doppler that held no line as if its lines were as strong there as within
    (the half rate has no such windows). A tail window expects the tip's fall-off
    (``tail_fall``): the estimate is within 2 % or marked ambiguous with the true order
    named (the recording itself, and its geometry with speeds, blades and phases drawn
    from seed 67; both -50 % unmarked without it)."""
    case = draw_case(seed, **ANY11007)
    flight, truth = make_recording(case)
    assert truth["visible"]
    assert_honest(estimate_rotor_speeds(flight), truth, flight)


# the geometry of the benchmark's second hold-out recording any7014 (1.3 GHz, 5.6 kHz, a
# flying four-rotor drone of 0.058 m three-blade rotors at 309 rev/s, one blade 3.0 dB
# weak): the rotors' spread closes the analysed band at ~730 Hz, below the first
# blade-passing line (3 x 309 Hz); only the weak blade's rotation-rate lines lie inside
ANY7014 = {k: v for k, v in asdict(draw_case(7014, duration_s=6.0)).items() if k not in ("name", "seed")}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [7014, 72])
def test_rotation_rate_lines_alone_set_their_level(seed):
    """any7014: every peak of the analysed band is a rotation-rate line (k = 1, 2) of the
    true rate; its blade-passing lines lie beyond the band. The true order's level was
    fitted on its blade-passing peaks alone, none, so it sat at the floor and its
    rotation-rate lines read as spurious: the order check chose 2/3 of the truth (whose
    blade-passing family explains the k = 2 lines), -33 %, not marked. A CPI whose
    explained peaks are all of the rotation-rate family takes its level from them
    (``rotation_level``): within 2 % or marked with the truth named (the recording, and
    its geometry drawn with seed 72; both -33 % unmarked with ``rotation_level=False``)."""
    case = draw_case(seed, **ANY7014)
    flight, truth = make_recording(case)
    assert truth["visible"]
    assert_honest(estimate_rotor_speeds(flight), truth, flight)


def test_tip_prior_is_a_log_normal_about_the_typical_tip_speed():
    """The blade-tip speed's prior: 0 at ``tip_speed_mps``, -z^2 / 2 with z the log of the
    tip speed over it in units of ``tip_speed_log_sd``; symmetric in the log (twice and
    half the centre alike); none without a blade length or with sd 0."""
    from microdoppler.rotors.order import OrderConfig, tip_log_prior

    cfg = OrderConfig()
    L = 0.1
    f0 = cfg.tip_speed_mps / (2 * np.pi * L)
    lp = tip_log_prior(np.array([f0, 2 * f0, f0 / 2, f0 * np.exp(cfg.tip_speed_log_sd)]), L, cfg)
    np.testing.assert_allclose(
        lp,
        [
            0.0,
            -(np.log(2) ** 2) / (2 * cfg.tip_speed_log_sd**2),
            -(np.log(2) ** 2) / (2 * cfg.tip_speed_log_sd**2),
            -0.5,
        ],
        atol=1e-12,
    )
    assert not tip_log_prior(np.array([f0, 3 * f0]), None, cfg).any()
    assert not tip_log_prior(np.array([f0, 3 * f0]), L, OrderConfig(tip_speed_log_sd=0.0)).any()
    with pytest.raises(ValueError, match="tip_speed_mps"):
        OrderConfig(tip_speed_mps=-1.0)


def _order_under(seed):
    """A drawn recording's lines (no order check) and a function that resolves their
    order under an ``OrderConfig``: (flight, truth, resolve)."""
    from microdoppler.rotors.order import resolve_order
    from microdoppler.rotors.speed import RotorSpeedConfig

    flight, truth = make_recording(draw_case(seed, duration_s=6.0))
    cfg = RotorSpeedConfig()
    lines = estimate_rotor_speeds(flight, config=cfg, order=False)
    B = int(flight.attrs["n_blades"])

    def rerun(c, n_blades=B):
        return estimate_rotor_speeds(flight, n_fft=lines.n_fft, n_blades=n_blades, config=c, order=False)

    return flight, truth, lambda ocfg: resolve_order(flight, lines, cfg, rerun=rerun, config=ocfg)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [11007, 9006])
def test_tip_prior_decides_between_orders_the_lines_explain_alike(seed):
    """any11007 (1.3 GHz, 0.052 m blades at 186 rev/s, one blade 6.8 dB weak) and any9006
    (9.4 GHz, 0.17 m three-blade rotors at 64 rev/s): two orders explain the lines within a factor of a few
    (relative likelihood 0.44 and 0.36), and the likelier put the tips at 31 and 206
    m/s, the truth at 61 and 69 m/s. Weighed with the tip speed's prior, the order is the
    truth's, within 2 %, and still marked ambiguous with the likelier rate listed at
    relative likelihood 1; without the prior (``tip_speed_log_sd=0``, ``order/3``) the
    likelier, more than 10 % off and marked."""
    from microdoppler.rotors.order import OrderConfig

    flight, truth, resolve = _order_under(seed)
    assert truth["visible"]
    est = resolve(OrderConfig())
    err, named, true_mean = score(est, truth, flight)
    o = est.info["order"]
    assert abs(err) <= 0.02 and o["ambiguous"] and o["tip_prior"]
    assert 1.0 in o["relative_likelihood"]
    flat = resolve(OrderConfig(tip_speed_log_sd=0.0))
    err0, _, _ = score(flat, truth, flight)
    assert abs(err0) > 0.10 and flat.info["order"]["ambiguous"] and flat.info["order"]["tip_prior"] is None


@pytest.mark.slow
def test_an_order_plausible_by_its_tip_speed_is_named():
    """any19055 (an eighth hold-out's recording: 1.3 GHz, 2.1 kHz, a hovering six-rotor
    drone of 0.050 m two-blade rotors at 220 rev/s, one blade 3.5 dB weak): the lines
    prefer half the rate (tips at 35 m/s) 40:1 over the truth (69 m/s). With the tip
    speed's prior at ``tip_speed_log_sd`` 0.4 (``order/6``) half the rate stayed chosen,
    -50 %, with the truth named by its posterior odds (~0.2, the order marked). At 0.3
    the truth is chosen, within 2 %, and the order stays ambiguous with the likelier
    rate listed at relative likelihood 1."""
    from microdoppler.rotors.order import OrderConfig

    flight, truth, resolve = _order_under(19055)
    assert truth["visible"]
    est = resolve(OrderConfig())
    err, named, true_mean = score(est, truth, flight)
    assert_honest(est, truth, flight)
    o = est.info["order"]
    assert abs(err) <= 0.02 and o["ambiguous"] and o["tip_prior"]
    i = [abs(a / true_mean - 0.5) <= 0.015 for a in o["alternatives_rev_s"]].index(True)
    assert o["relative_likelihood"][i] == 1.0
    old = resolve(OrderConfig(tip_speed_log_sd=0.4))
    err0, named0, _ = score(old, truth, flight)
    o0 = old.info["order"]
    assert abs(err0 + 0.5) < 0.02 and o0["ambiguous"]
    i = [abs(a / true_mean - 1) <= 0.03 for a in o0["alternatives_rev_s"]].index(True)
    assert o0["relative_likelihood"][i] < 0.05 <= o0["posterior_odds"][i]


def test_tail_reach_inverts_the_tips_fall_off():
    """The tail's reach (``tail_level``) is where the tip's Airy fall-off comes to the
    given depth: 8.4 dB at m = 1, 20 dB at m = 2 (Ai(m) / Ai(0)); deeper reaches farther;
    no depth, no reach."""
    from microdoppler.rotors.order import _tail_fall_db, _tail_reach_m

    for m in (0.5, 1.0, 2.0, 3.0):
        depth = float(_tail_fall_db(np.array([m]), np.array([0.0]), np.array([1.0]))[0])
        assert _tail_reach_m(depth) == pytest.approx(m, abs=0.01)
    assert 8.0 < float(_tail_fall_db(np.array([1.0]), np.array([0.0]), np.array([1.0]))[0]) < 9.0
    assert _tail_reach_m(0.0) == 0.0 and _tail_reach_m(-3.0) == 0.0
    assert _tail_reach_m(10.0) < _tail_reach_m(20.0) < _tail_reach_m(30.0)


@pytest.mark.slow
def test_lines_past_a_subharmonics_tips_at_their_level_rule_it_out():
    """any9061 (5.8 GHz, 12 kHz, six 0.079 m two-blade rotors at 193 rev/s, one blade 7.3
    dB weak, flying; not visible by the generator's rule): half the rate explains the
    lines' dense windows best, and its tips' Doppler (1.9 kHz) with 2 beta^(1/3)
    harmonics of tail let the lines reach 2.9 kHz: -50 %, unmarked (``order/4``). The
    strongest line stands 29 dB over the floor, so no line 13 dB over it can lie more
    than ~2 (beta / 2)^(1/3) harmonics past the tips' Doppler (20 dB down the Airy
    fall-off, + 5 dB): half the rate is ruled out and the estimate is within 2 %."""
    from microdoppler.rotors.order import OrderConfig

    flight, truth, resolve = _order_under(9061)
    est = resolve(OrderConfig())
    err, named, true_mean = score(est, truth, flight)
    assert abs(err) <= 0.02 and est.info["order"]["tail_harmonics"] < 2 * (4 * np.pi * 0.0794 / 0.0517) ** (1 / 3)
    old = resolve(OrderConfig(tail_level=False))
    err0, _, _ = score(old, truth, flight)
    assert abs(err0 + 0.5) < 0.05 and not old.info["order"]["ambiguous"]


@pytest.mark.slow
def test_rotors_split_between_two_rates_are_scaled_to_the_chosen_one_and_marked():
    """any21027 (the ninth hold-out: not visible by the generator's rule): the screen's
    rate 74 rev/s explains the lines best (the truth 73), but no re-measurement finds
    its comb, and the lines' estimate scaled to it has rotors at ~0.8x and ~1.2x; those
    far from their neighbours' median go to it (37 of 92 rotor-CPIs), and the speeds
    reported come to 60 rev/s: -18 %, unmarked (``order/5``). The speeds depart from
    the chosen rate by more than ``depart_max``: they are scaled to it (within 2 % of the
    truth), the order is ambiguous with the speeds as measured listed, and every CPI's
    error lies within 2 sigma."""
    from microdoppler.rotors.order import OrderConfig

    flight, truth, resolve = _order_under(21027)
    est = resolve(OrderConfig())
    err, named, true_mean = score(est, truth, flight)
    o = est.info["order"]
    assert o["ambiguous"] and o["split"] and abs(o["departs"]) > OrderConfig().depart_max
    assert abs(err) <= 0.02
    assert abs(named[-1] / true_mean - 1) > 0.10 and o["relative_likelihood"][-1] == 1.0
    v = est.valid
    tm = true_cpi_means(truth, est.time_s, est.n_fft, flight.prf_hz).mean(axis=1)
    assert np.all(np.abs(est.common_rev_s[v] - tm[v]) <= 2 * est.common_std_rev_s[v])
    assert "departed from the chosen rate" in ambiguity_line(est)
    old = resolve(OrderConfig(depart_max=np.inf))
    err0, _, _ = score(old, truth, flight)
    assert abs(err0) > 0.10 and not old.info["order"]["ambiguous"]
    assert abs(named[-1] / float(np.median(old.common_rev_s[old.valid])) - 1) < 0.001


@pytest.mark.slow
@pytest.mark.parametrize("seed", [2, 30, 58])
def test_drawn_recordings(seed):
    """Recordings drawn from the generator's seeds (carrier, PRF, rotors, blades, set-up,
    balance, levels; 2: L band, one weak blade, flying; 30: C band, equal blades, the
    blade flash folded past +-PRF/2; 58: three blades, one weak, hovering, one
    blade-passing pair visible): within 2 % or honestly ambiguous."""
    case = draw_case(seed, duration_s=4.0)
    flight, truth = make_recording(case)
    assert truth["visible"]
    assert_honest(estimate_rotor_speeds(flight), truth, flight)


# ------------------------------------------------------------------ what the store and the user see


def test_ambiguity_reaches_the_store_and_the_line():
    """An ambiguous order names its alternatives in ``motors_radar`` and in one line,
    and rpm_std holds the mixture's spread (the alternatives within 2 sigma when their
    likelihood is comparable)."""
    from types import SimpleNamespace

    order = {
        "method": "order/1",
        "chosen_rev_s": 80.8,
        "lines_rev_s": 80.8,
        "ratio_to_lines": 1.0,
        "ambiguous": True,
        "remeasured": "kept",
        "order_rel_std": 0.7,
        "alternatives_rev_s": [161.6],
        "relative_likelihood": [0.77],
    }
    est = SimpleNamespace(flight_id="stand01", info={"order": order})
    line = ambiguity_line(est)
    assert line is not None and "80.8 or 161.6 rev/s" in line and "likelihood ratio 1.3" in line
    attrs = order_attrs(est)
    assert attrs["rotor_order_alternatives_rev_s"] == [161.6]
    assert attrs["rotor_order_relative_likelihood"] == [0.77]
    assert ambiguity_line(SimpleNamespace(flight_id="x", info={"order": {**order, "ambiguous": False}})) is None
    # an alternative plausible once weighed with the tip speed's prior: both ratios named
    line = ambiguity_line(
        SimpleNamespace(
            flight_id="x", info={"order": {**order, "relative_likelihood": [0.025], "posterior_odds": [0.2]}}
        )
    )
    assert "likelihood ratio 40; with the tip speed's prior 5;" in line


@pytest.mark.slow
def test_store_carries_the_order(tmp_path):
    """The estimate written into a flight-zarr/1 store keeps the order's attributes and
    its rpm_std includes the order's uncertainty."""
    from microdoppler.io.flightzarr import read_flight, write_flight

    case = draw_case(25, duration_s=4.0)
    flight, truth = make_recording(case)
    est = estimate_rotor_speeds(flight)
    write_flight(tmp_path / "f.zarr", est.with_flight(flight))
    back = read_flight(tmp_path / "f.zarr")
    mr = back.attrs["motors_radar"]
    for key in ("rotor_order", "rotor_order_alternatives_rev_s", "rotor_order_relative_likelihood"):
        assert key in mr
    o = est.info["order"]
    v = est.valid
    rel_std = np.asarray(mr["rpm_std"], float).mean(axis=1) / (60 * est.common_rev_s[v])
    assert np.all(rel_std >= o["order_rel_std"] * 0.99)


def test_benchmark_join_puts_halves_in_seed_order_and_refuses_a_seed_twice(tmp_path):
    """benchmarks/eval_any_radar.py --join: halves run side by side give one table, rows
    in seed order, the summary counted over both; a seed in two runs is refused with
    the files named."""
    import json
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import eval_any_radar

    def row(seed, error, visible=True, ambiguous=False):
        return {
            "name": f"any{seed}",
            "seed": seed,
            "carrier_ghz": 3.3,
            "setup": "hover",
            "balance": "equal",
            "visible": visible,
            "ok": True,
            "error": error,
            "ambiguous": ambiguous,
            "truth_listed": True,
            "n_cpi": 10,
            "n_2sigma": 9,
            "seconds": 6.0,
            "duration_s": 6.0,
            "n_rotors": 4,
            "prf_hz": 5000.0,
        }

    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps({"rows": [row(3, 0.001), row(1, 0.5)], "wall_s": 10.0, "timing": None}))
    b.write_text(json.dumps({"rows": [row(2, -0.3, ambiguous=True)], "wall_s": 12.0, "timing": None}))
    out = tmp_path / "all.json"
    assert eval_any_radar.main(["--join", str(a), str(b), "--json", str(out), "--csv", str(tmp_path / "t.csv")]) == 0
    joined = json.loads(out.read_text())
    assert [r["seed"] for r in joined["rows"]] == [1, 2, 3]
    assert joined["summary_lines"][0].startswith("visible recordings within 2 %: 1 of 3")
    assert joined["summary_lines"][1].startswith(
        "off by > 10 % and not marked ambiguous: 1 of 3 with an estimate; any1 +50.0 %"
    )
    assert joined["table"][0]["recordings"] == 3 and joined["wall_s"] == 12.0
    b.write_text(json.dumps({"rows": [row(3, 0.0)], "wall_s": 1.0, "timing": None}))
    with pytest.raises(SystemExit, match="a seed appears twice"):
        eval_any_radar.main(["--join", str(a), str(b)])


def test_benchmark_compare_pairs_runs_by_recording(tmp_path):
    """benchmarks/compare_any_radar_runs.py: two runs over the same recordings give the
    counts before and after, the paired difference with its interval, and the list of
    recordings that moved (an unmarked gross error marked, another's CPIs covered); a
    recording twice in one side is refused; a run of some recordings (--rest-unchanged)
    and a later run of some before rows (--before-update) take their rows' places."""
    import json
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import compare_any_radar_runs

    def row(seed, error, ambiguous=False, n_2sigma=9):
        return {
            "name": f"any{seed}",
            "seed": seed,
            "carrier_ghz": 3.3,
            "n_blades": 2,
            "visible": True,
            "ok": True,
            "error": error,
            "ambiguous": ambiguous,
            "n_cpi": 10,
            "n_2sigma": n_2sigma,
            "alternatives_rev_s": [],
        }

    before = [row(1, 0.001), row(2, -0.5), row(3, 0.01, n_2sigma=5)]
    after = [row(1, 0.001 + 1e-6), row(2, -0.5, ambiguous=True), row(3, 0.01, n_2sigma=10)]
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps({"rows": before}))
    b.write_text(json.dumps({"rows": after}))
    out = tmp_path / "p.json"
    assert compare_any_radar_runs.main(["--before", str(a), "--after", str(b), "--json", str(out)]) == 0
    p = json.loads(out.read_text())
    assert p["n_recordings"] == 3
    off = p["off > 10 % unmarked (estimate in both)"]
    assert (off["before"], off["after"], off["n"]) == (1, 0, 3) and off["ci95"][0] < 0 <= off["ci95"][1]
    gross = p["off > 10 % marked or not (estimate in both)"]
    assert (gross["before"], gross["after"], gross["diff"]) == (1, 1, 0.0)
    cov = p["visible CPIs within 2 sigma (same CPIs)"]
    assert (cov["before"], cov["after"], cov["n"]) == (23, 28, 30)
    assert p["within 2 % (visible)"]["diff"] == 0.0
    assert [c["name"] for c in p["changed"]] == ["any2", "any3"]
    # a run of the reachable recordings only: the rest count as unchanged
    b.write_text(json.dumps({"rows": after[1:2]}))
    assert (
        compare_any_radar_runs.main(["--before", str(a), "--after", str(b), "--json", str(out), "--rest-unchanged"])
        == 0
    )
    p = json.loads(out.read_text())
    assert p["n_recordings"] == 3 and p["rest_unchanged"] and [c["name"] for c in p["changed"]] == ["any2"]
    assert p["off > 10 % unmarked (estimate in both)"]["after"] == 0
    # a later run of some --before recordings replaces their rows before the comparison
    u = tmp_path / "u.json"
    u.write_text(json.dumps({"rows": [row(2, -0.5, ambiguous=True)]}))
    assert (
        compare_any_radar_runs.main(
            ["--before", str(a), "--before-update", str(u), "--after", str(b), "--json", str(out), "--rest-unchanged"]
        )
        == 0
    )
    p = json.loads(out.read_text())
    assert p["changed"] == [] and p["off > 10 % unmarked (estimate in both)"]["before"] == 0
    b.write_text(json.dumps({"rows": [row(4, 0.0)]}))
    with pytest.raises(SystemExit, match="not in --before"):
        compare_any_radar_runs.main(["--before", str(a), "--after", str(b), "--rest-unchanged"])
    with pytest.raises(SystemExit, match="--before-update"):
        compare_any_radar_runs.main(["--before", str(a), "--before-update", str(b), "--after", str(u)])
    a.write_text(json.dumps({"rows": before + [row(1, 0.0)]}))
    with pytest.raises(SystemExit, match="appears twice"):
        compare_any_radar_runs.main(["--before", str(a), "--after", str(b)])


def test_benchmark_pool_joins_runs_with_later_rows_in_place(tmp_path):
    """benchmarks/pool_any_radar_runs.py: disjoint runs joined, a later run of some
    recordings (--update) in their rows' place, a seed range kept; the counts and their
    intervals over recordings, and the visible misses by kind. Overlapping runs and an
    update of a recording no run holds are refused."""
    import json
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import pool_any_radar_runs

    def row(seed, error, ambiguous=False, visible=True, listed=False):
        return {
            "name": f"any{seed}",
            "seed": seed,
            "visible": visible,
            "ok": error is not None,
            "error": error,
            "ambiguous": ambiguous,
            "truth_listed": listed,
            "n_cpi": 10 if error is not None else 0,
            "n_2sigma": 9 if error is not None else 0,
        }

    a, b, u, out = (tmp_path / n for n in ("a.json", "b.json", "u.json", "p.json"))
    a.write_text(json.dumps({"rows": [row(1, 0.001), row(2, -0.5, ambiguous=True, listed=True)]}))
    b.write_text(json.dumps({"rows": [row(7, 0.2), row(8, None), row(9, 0.01, visible=False)]}))
    u.write_text(json.dumps({"rows": [row(7, 0.015)]}))
    assert pool_any_radar_runs.main(["--runs", str(a), str(b), "--json", str(out)]) == 0
    p = json.loads(out.read_text())
    w = p["within 2 % (visible)"]
    assert (w["count"], w["n"]) == (1, 4) and w["ci95"][0] <= 0.25 <= w["ci95"][1]
    assert p["within 2 % or ambiguous with the truth listed (visible)"]["count"] == 2
    off = p["off > 10 % unmarked (with estimate)"]
    assert (off["count"], off["n"]) == (1, 4)
    m = p["visible misses"]
    assert m["ambiguous, truth listed"] == ["any2"] and m["no estimate"] == ["any8"] and m["unmarked"] == ["any7"]
    assert (
        pool_any_radar_runs.main(["--runs", str(a), str(b), "--update", str(u), "--min-seed", "5", "--json", str(out)])
        == 0
    )
    p = json.loads(out.read_text())
    assert p["n_recordings"] == 3 and p["within 2 % (visible)"]["count"] == 1
    assert p["off > 10 % unmarked (with estimate)"]["count"] == 0 and p["rows_from"] == {str(b): 2, str(u): 1}
    with pytest.raises(SystemExit, match="also in"):
        pool_any_radar_runs.main(["--runs", str(a), str(a)])
    u.write_text(json.dumps({"rows": [row(5, 0.0)]}))
    with pytest.raises(SystemExit, match="not in --runs"):
        pool_any_radar_runs.main(["--runs", str(a), "--update", str(u)])
