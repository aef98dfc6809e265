"""Evaluate the diagnosis on flights with known effects, one or two at once (not run in CI).

Issue 12 section 5. A plan of flights is drawn from ``--seed`` (which the diagnosis
never sees; each flight gets a neutral id ``fNNNN`` in a shuffled order):

- ``--flights-per-cause`` flights with one cause, for every catalog cause (the
  catalog's model extensions, ``blade_imbalance`` included; ``unexplained`` is a
  goodness of fit, not a cause one can plant);
- ``--two-cause`` flights with two causes at once (the 21 pairs in turn, in a random
  order, then again);
- ``--clean`` flights without an effect;
- ``--outside`` flights with one effect no catalog cause describes (issue 34): from
  the independent generator a second scatterer on the airframe (offset +-U(20, 60) Hz
  from the body, U(-18, -8) dB, wandering U(0, 4) Hz), a wrong declared blade count
  (3 blades, 2 declared) or a range-cell straddle (U(4, 8) dB over U(8, 16) s), in
  turn; from the emulator flights altered here (:func:`_emulate_outside`): the same
  second scatterer added to the measured I/Q on the body's own carrier phase, the
  store's declared blade count set to 3 (the blades are 2), or the same slow straddle
  applied to the target's echo (before clutter and noise), in turn.

Half of each group (alternating) comes from the project's emulator
(``microdoppler.emulator``, radars ``radar1``/``radar2`` in turn, Inspire 2 or
Matrice 300 flying the trials' loops) and half from the independent generator of
``tests/independent_generator.py`` (no code shared with the emulator; its radars
``gen_l``/``gen_s`` in turn, a straight leg at 5-20 m/s radial speed, telegraph
fading, a critically damped body process, Gaussian or 1/f-like phase noise).

Effect parameters are drawn in the catalog's detectable ranges: asymmetry_db
+-U(3, 6); fading_std_db U(3, 6) with timescale_s U(1, 2); body_std_db U(3, 6) with
timescale_s log-uniform in 0.05-3 s; lag_s +-U(0.3, 1.0); scale 1 +- U(0.05, 0.12);
skirt_dbc_hz U(-72, -60) (the emulator's flat process of that skirt; the independent
generator's Gaussian or 1/f-like shape at random); imbalance_db U(3, 10) (one blade of
every rotor weaker: the emulator's ``blade_imbalance``, as its worlds' airframes carry
it, and the independent generator's weak blade 0).

Body SNR: a target measured SNR is drawn per flight, U(36, 48) dB for a share
``--high-snr-share`` of the flights, else U(20, 36) dB; the flight is made at a
nominal SNR and remade (at most twice) with the nominal SNR moved by the shortfall
until the measured SNR (``microdoppler.spectra.snr.flight_body_snr_db``, mean over the
spectrogram timesteps, the project's one SNR measure) is within 2 dB of the target
and on the same side of 36 dB. Every summary splits flights by this measured SNR.

Reported (95 % flight-bootstrap CIs, :mod:`microdoppler.stats.bootstrap`, the flight as the
unit, resampled within its design group: clean / one cause per cause / two causes):

- true causes named (recall over all true causes), spurious causes on two-cause
  flights (share of flights naming a cause they do not have), false alarms on clean
  flights (share naming any cause), skipped flights; per SNR band and generator;
- per cause: recall and precision per SNR band and generator;
- per canonical parameter of a named true cause: error (absolute for asymmetry_db
  [dB] and lag_s [s]; relative for fading_std_db, body_std_db, both timescale_s and
  scale - 1; for skirt_dbc_hz the relative error of the linear density,
  10^(d/10) - 1 with d the error in dB), median |error| and share within the target
  (20 %; 1 dB; 0.1 s);
- recall per cause in SNR bins (the detectable range below 36 dB) and, for
  phase noise, by the rise of the floor 35-95 Hz from the clutter line over the
  target-free background;
- issue 34's rates (:func:`summarise_issue34`): ``blade_imbalance`` named on flights
  with a weak blade, ``imbalance_db`` within 1.5 dB, spurious ``blade_imbalance`` on
  balanced flights, ``unexplained`` on outside flights (and ``none`` there) and on
  flights holding only catalog causes. ``unexplained`` is left out of the spurious
  causes and false alarms above (it is reported on its own);
- per out-of-catalog second scatterer, its largest rise over the same flight without
  it in the goodness of fit's bands (:func:`oddity_rise_db`), and for those below the
  test's margin the share of explained flights that misfit by as much (the bound).

Paired before/after (``--before-src DIR``, the ``src/`` of an older checkout): every
flight holding only catalog causes other than ``blade_imbalance`` (one-cause, two-cause
and clean) is written once as a flight-zarr store (``--stores``, default a temporary
folder), diagnosed from that store by this code and, after the loop, by the older code
(``benchmarks/diagnose_stores.py`` in a subprocess with ``PYTHONPATH=DIR``): recall per
cause before and after with the paired difference, and spurious catalog causes, each
with a flight-bootstrap CI (:func:`summarise_paired`).

    python benchmarks/eval_diagnosis.py --seed 1 --json results/diagnosis/eval.json --workers 2
    python benchmarks/eval_diagnosis.py --flights-per-cause 2 --two-cause 2 --clean 2 --duration-s 20  # quick
    python benchmarks/eval_diagnosis.py --seed 34 --flights-per-cause 4 --two-cause 12 --clean 4 --outside 12 \
        --duration-s 20 --before-src ../eval34_before/src --json eval.json   # issue 34, with before/after
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import itertools  # noqa: E402
import json  # noqa: E402
import secrets  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from dataclasses import replace  # noqa: E402
from functools import partial  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from microdoppler.stats.bootstrap import draw_flights, interval, ratio_replicates, resolved  # noqa: E402
from microdoppler.causes.catalog import CATALOG, UNEXPLAINED  # noqa: E402
from diagnose_stores import diagnose_with_fit  # noqa: E402  (this folder: the script's own)
from microdoppler.emulator import world as emu_world  # noqa: E402
from microdoppler.emulator.world import FlightSpec, emulate_flight  # noqa: E402
from microdoppler.io.flightzarr import read_flight, write_flight  # noqa: E402
from microdoppler.io.outputs import atomic_file  # noqa: E402
from microdoppler.spectra.snr import flight_body_snr_db  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from independent_generator import GenCase, make_flight  # noqa: E402

#: the causes one can plant: the catalog's model extensions (not "none", not "unexplained")
CAUSE_LIST = [c for c in CATALOG if c not in ("none", UNEXPLAINED)]
#: causes the code before issue 34 could name (the paired before/after comparison)
OLD_CAUSES = [c for c in CAUSE_LIST if c != "blade_imbalance"]
#: out-of-catalog effects per generator, in turn (module docstring)
OUTSIDE = {
    "independent": ["second_scatterer", "true_n_blades", "range_straddle"],
    "emulator": ["second_scatterer", "declared_n_blades", "range_straddle"],
}
REPO = Path(__file__).resolve().parents[1]
HIGH_SNR_DB = 36.0
#: bins of measured body SNR for the detectable range [dB]
SNR_BINS_DB = (20.0, 24.0, 28.0, 32.0, 36.0, 40.0, np.inf)
#: canonical parameters and their error kind: "abs" (target 1 dB / 0.1 s), "rel"
#: (relative, target 20 %), "rel_m1" (relative error of value - 1), "rel_db" (dB
#: error expressed as the relative error of the linear density)
PARAMS = {
    "sideband_asymmetry": {"asymmetry_db": "abs"},
    "sideband_fading": {"fading_std_db": "rel", "timescale_s": "rel"},
    "body_fluctuation": {"body_std_db": "rel", "timescale_s": "rel"},
    "motor_log_lag": {"lag_s": "abs"},
    "motor_speed_scale": {"scale": "rel_m1"},
    "phase_noise": {"skirt_dbc_hz": "rel_db"},
    "blade_imbalance": {"imbalance_db": "abs"},
}
TOL = {"asymmetry_db": 1.0, "lag_s": 0.1, "imbalance_db": 1.5}
REL_TOL = 0.2
#: rough cost model for the printed estimate [s]: per second of flight emulated,
#: emulations per flight, diagnosis per second of flight, and the earlier code's
#: diagnosis of a stored flight per second of flight (one core, 2026-11-26)
EMU_S_PER_FLIGHT_S, EMULATIONS_PER_FLIGHT, DIAG_S, DIAG_BEFORE_S = 0.02, 1.5, 0.06, 0.02


# ----------------------------------------------------------------------------- plan
def draw_params(cause: str, rng: np.random.Generator) -> dict:
    """Canonical parameters of one cause in the catalog's detectable range."""
    sign = float(rng.choice([-1.0, 1.0]))
    if cause == "sideband_asymmetry":
        return {"asymmetry_db": sign * rng.uniform(3, 6)}
    if cause == "sideband_fading":
        return {"fading_std_db": rng.uniform(3, 6), "timescale_s": rng.uniform(1, 2)}
    if cause == "body_fluctuation":
        return {"body_std_db": rng.uniform(3, 6), "timescale_s": float(np.exp(rng.uniform(np.log(0.05), np.log(3.0))))}
    if cause == "motor_log_lag":
        return {"lag_s": sign * rng.uniform(0.3, 1.0)}
    if cause == "motor_speed_scale":
        return {"scale": 1 + sign * rng.uniform(0.05, 0.12)}
    if cause == "phase_noise":
        return {"skirt_dbc_hz": rng.uniform(-72, -60)}
    if cause == "blade_imbalance":
        return {"imbalance_db": rng.uniform(3, 10)}
    raise ValueError(cause)


def draw_outside(kind: str, rng: np.random.Generator) -> dict:
    """One out-of-catalog effect (as ``benchmarks/eval_unexplained.py`` draws it)."""
    if kind == "second_scatterer":
        return {
            kind: {
                "offset_hz": float(rng.choice([-1, 1]) * rng.uniform(20, 60)),
                "level_db": float(rng.uniform(-18, -8)),
                "wander_hz": float(rng.uniform(0, 4)),
            }
        }
    if kind in ("true_n_blades", "declared_n_blades"):
        return {kind: 3}
    if kind == "range_straddle":
        return {kind: {"depth_db": float(rng.uniform(4, 8)), "period_s": float(rng.uniform(8, 16))}}
    raise ValueError(kind)


def make_plan(
    seed: int,
    per_cause: int,
    two_cause: int,
    clean: int,
    duration_s: float,
    high_share: float,
    causes: list[str] | None = None,
    falloff_db: tuple | None = None,
    generators: str = "both",
    outside: int = 0,
) -> list[dict]:
    """The flights to make, drawn from ``seed``: one dict per flight (JSON-able).

    ``causes``: restrict the one-cause flights and the two-cause pairs to these
    catalog causes (default: all of :data:`CAUSE_LIST`); the plan then differs from
    the full one drawn from the same seed. ``falloff_db``: (lo, hi) [dB per
    harmonic]: the emulator flights' sideband fall-off is drawn log-uniformly in it
    (default: the emulator's own draw, ``world.FALLOFF_DB``), from a generator of its
    own (the rest of the plan is the same). ``generators``: ``both`` (alternating),
    ``emulator`` or ``independent`` only. ``outside``: flights with an out-of-catalog
    effect (:data:`OUTSIDE`, in turn per generator), drawn after the others, their
    effects from a generator of their own."""
    rng = np.random.default_rng(seed)
    rng_falloff = np.random.default_rng([seed, 0xFA11])
    rng_odd = np.random.default_rng([seed, 0x0DD])
    cause_list = list(CAUSE_LIST) if not causes else [c for c in CAUSE_LIST if c in causes]
    groups: list[tuple[str, list[str]]] = []
    for c in cause_list:
        groups += [("one", [c])] * per_cause
    pairs = list(itertools.combinations(cause_list, 2))
    order: list = []
    while pairs and len(order) < two_cause:
        order += [pairs[i] for i in rng.permutation(len(pairs))]
    groups += [("two", list(p)) for p in order[:two_cause]]
    groups += [("clean", [])] * clean
    groups += [("outside", [])] * outside
    plan = []
    count: dict = {}
    for kind, causes in groups:
        # generators alternate within each group (a cause's one-cause flights, the
        # two-cause flights, the clean flights); each generator's radars alternate
        key = kind if kind != "one" else causes[0]
        k = count[key] = count.get(key, -1) + 1
        gen = ["emulator", "independent"][k % 2] if generators == "both" else generators
        j = count[gen] = count.get(gen, -1) + 1
        radar = {"emulator": ["radar1", "radar2"], "independent": ["gen_l", "gen_s"]}[gen][j % 2]
        hi = rng.uniform() < high_share
        p = {
            "kind": kind,
            "generator": gen,
            "radar": radar,
            "effects": {c: draw_params(c, rng) for c in causes},
            "target_snr_db": float(rng.uniform(36, 48) if hi else rng.uniform(20, 36)),
            "duration_s": duration_s,
            "seed": int(rng.integers(2**31)),
        }
        if gen == "emulator":
            p.update(
                drone_model=str(rng.choice(["inspire2", "matrice300"])),
                mean_range_m=float(rng.uniform(1000, 3000)),
                height_m=float(rng.choice([60.0, 80.0, 100.0])),
                speed_mps=float(rng.uniform(3, 12)),
                direction=int(rng.choice([1, -1])),
            )
            if falloff_db is not None:
                lo, hi = np.log(falloff_db[0]), np.log(falloff_db[1])
                p["harmonic_falloff_db"] = float(np.exp(rng_falloff.uniform(lo, hi)))
        else:
            p.update(drone_model="gen_quad", speed_mps=float(rng.uniform(5, 20)))
            if "phase_noise" in p["effects"]:
                p["pn_shape"] = str(rng.choice(["gauss", "flicker"]))
        if kind == "outside":
            o = count[f"outside:{gen}"] = count.get(f"outside:{gen}", -1) + 1
            p["oddities"] = draw_outside(OUTSIDE[gen][o % len(OUTSIDE[gen])], rng_odd)
        plan.append(p)
    for i, j in enumerate(rng.permutation(len(plan))):  # neutral ids, in a shuffled order
        plan[j]["flight_id"] = f"f{i:04d}"
    return sorted(plan, key=lambda p: p["flight_id"])


# ----------------------------------------------------------------------------- one flight
def _emulate_outside(spec: FlightSpec, oddities: dict, seed: int):
    """Emulate ``spec`` and alter it with one out-of-catalog effect (module docstring).

    ``second_scatterer`` and ``range_straddle`` need the target's true range per
    pulse: the emulator's range-cell gain (``world._straddle_gain``, applied to the
    target's echo before clutter, phase noise and thermal noise are added) is wrapped
    for the call; the straddle multiplies its gain by a raised cosine of ``depth_db``
    over ``period_s``, the second scatterer is added afterwards to the measured I/Q:
    the body's amplitude times 10^(level_db/20), the body's carrier phase
    exp(-j 4 pi R / lambda) and the range-cell gain, and its own Doppler
    ``offset_hz`` + ``wander_hz`` sin(2 pi t / U(4, 8) s). ``declared_n_blades``: the
    store declares that many blades (the emulated ones have 2)."""
    rng = np.random.default_rng([seed, 0x0DD])
    prf = emu_world.radar_site(spec.radar_id).radar.prf_hz
    orig = emu_world._straddle_gain
    seen: dict = {}

    def gain(range_m):
        g = orig(range_m)
        seen["range_m"], seen["gain"] = np.asarray(range_m, np.float64), g
        if "range_straddle" in oddities:
            q = oddities["range_straddle"]
            t = np.arange(len(range_m)) / prf
            drift_db = -q["depth_db"] * 0.5 * (1 - np.cos(2 * np.pi * t / q["period_s"] + rng.uniform(0, 2 * np.pi)))
            g = (g * 10 ** (drift_db / 20)).astype(np.float32)
        return g

    emu_world._straddle_gain = gain
    try:
        flight, truth = emulate_flight(spec)
    finally:
        emu_world._straddle_gain = orig
    if "second_scatterer" in oddities:
        q = oddities["second_scatterer"]
        n = len(flight.iq)
        t = np.arange(n) / prf
        lam = 299792458.0 / flight.attrs["carrier_hz"]
        wander = q["wander_hz"] * np.sin(2 * np.pi * t / rng.uniform(4.0, 8.0) + rng.uniform(0, 2 * np.pi))
        ph = 2 * np.pi * np.cumsum(q["offset_hz"] + wander) / prf - 4 * np.pi * seen["range_m"][:n] / lam
        extra = truth["s_body"] * 10 ** (q["level_db"] / 20) * seen["gain"][:n] * np.exp(1j * ph)
        flight = replace(flight, iq=(flight.iq + extra).astype(np.complex64))
    if "declared_n_blades" in oddities:
        flight = replace(flight, attrs={**flight.attrs, "n_blades": int(oddities["declared_n_blades"])})
    return flight


def _make(p: dict, nominal_snr_db: float):
    odd = p.get("oddities", {})
    if p["generator"] == "emulator":
        spec = FlightSpec(
            p["flight_id"],
            "drone",
            drone_model=p["drone_model"],
            radar_id=p["radar"],
            duration_s=p["duration_s"],
            mean_range_m=p["mean_range_m"],
            height_m=p["height_m"],
            speed_mps=p["speed_mps"],
            direction=p["direction"],
            snr_db=nominal_snr_db,
            effects=p["effects"],
            seed=p["seed"],
            harmonic_falloff_db=p.get("harmonic_falloff_db"),
            airframe=f"{p['drone_model']}-weak" if "blade_imbalance" in p["effects"] else "",
        )
        if odd:
            return _emulate_outside(spec, odd, p["seed"])
        flight, _ = emulate_flight(spec)
        return flight
    eff = {c: dict(v) for c, v in p["effects"].items()}
    if "phase_noise" in eff:
        eff["phase_noise"]["shape"] = p["pn_shape"]
    case = GenCase(
        p["flight_id"],
        p["seed"],
        p["radar"],
        eff,
        duration_s=p["duration_s"],
        snr_db=nominal_snr_db,
        speed_mps=p["speed_mps"],
        oddities=odd,
    )
    return make_flight(case)[0]


def is_paired(p: dict) -> bool:
    """Whether the flight enters the before/after comparison: only catalog causes the
    code before issue 34 knew (no ``blade_imbalance``, no out-of-catalog effect)."""
    return p["kind"] != "outside" and "blade_imbalance" not in p["effects"]


def _snr_db(flight) -> float:
    s = flight_body_snr_db(flight)
    s = s[np.isfinite(s)]
    return float(np.mean(s)) if len(s) else float("nan")


def _floor_rise_db(flight) -> float:
    """Median floor 35-95 Hz from the clutter line: flight over its background [dB]
    (Hann periodograms of 4096 pulses, half overlap)."""

    def floor(iq):
        n, hop = 4096, 2048
        w = np.hanning(n)
        k = 1 + (len(iq) - n) // hop
        idx = np.arange(k)[:, None] * hop + np.arange(n)[None, :]
        p = np.abs(np.fft.fft(np.asarray(iq, np.complex128)[idx] * w, axis=1)) ** 2
        f = np.abs(np.fft.fftfreq(n, 1.0 / flight.prf_hz))
        return np.median(p[:, (f > 35) & (f < 95)])

    return float(10 * np.log10(floor(flight.iq) / floor(flight.background_iq)))


def param_error(name: str, kind: str, truth: float, fit: float) -> tuple[float, bool]:
    """(error, within target) of one canonical parameter (see :data:`PARAMS`)."""
    if kind == "abs":
        e = fit - truth
        return float(e), bool(abs(e) <= TOL[name])
    if kind == "rel":
        e = (fit - truth) / abs(truth)
    elif kind == "rel_m1":
        e = ((fit - 1) - (truth - 1)) / abs(truth - 1)
    elif kind == "rel_db":
        e = 10 ** ((fit - truth) / 10) - 1
    else:
        raise ValueError(kind)
    return float(e), bool(abs(e) <= REL_TOL)


#: the OU-type parameters: (cause, size key, timescale key)
OU_PARAMS = {"sideband_fading": ("fading_std_db", "timescale_s"), "body_fluctuation": ("body_std_db", "timescale_s")}


def ideal_within(
    size_db: float, tau_s: float, duration_s: float, n_sim: int = 400, seed: int = 0
) -> tuple[float, float]:
    """Probability that an ideal observer gets the size and the 1/e time of a dB
    Ornstein-Uhlenbeck gain within :data:`REL_TOL` of the truth.

    The ideal observer sees the process itself (no measurement noise, no analysis
    window, no other cause), sampled at ``min(0.05 s, tau/10)`` over the flight's
    ``duration_s``, and fits an AR(1) exactly (sample variance after removing the
    mean; tau = -dt / ln(lag-1 autocorrelation)). Every real estimator has less to
    go on, so its share within target can at best match this one.

    Returns
    -------
    (p_size, p_tau) : shares of ``n_sim`` simulated flights within target.
    """
    from scipy.signal import lfilter

    rng = np.random.default_rng([seed, int(round(1e4 * tau_s)), int(round(10 * duration_s))])
    dt = min(0.05, tau_s / 10)
    n = int(duration_s / dt)
    phi = np.exp(-dt / tau_s)
    e = rng.standard_normal((n_sim, n)) * size_db * np.sqrt(1 - phi**2)
    zi = phi * size_db * rng.standard_normal((n_sim, 1))
    x, _ = lfilter([1.0], [1.0, -phi], e, axis=1, zi=zi)
    x -= x.mean(axis=1, keepdims=True)
    var = np.mean(x**2, axis=1)
    rho = np.sum(x[:, 1:] * x[:, :-1], axis=1) / np.sum(x**2, axis=1)
    tau_hat = np.where(rho > 0, -dt / np.log(np.clip(rho, 1e-12, 1 - 1e-12)), 0.0)
    p_size = float(np.mean(np.abs(np.sqrt(var) / size_db - 1) <= REL_TOL))
    p_tau = float(np.mean(np.abs(tau_hat / tau_s - 1) <= REL_TOL))
    return p_size, p_tau


def add_ideal(errors: dict, p: dict) -> None:
    """Put the ideal observer's share (:func:`ideal_within`) into the ``errors`` entries
    of the planned flight ``p``'s OU-type parameters that were estimated."""
    for c, (size_key, tau_key) in OU_PARAMS.items():
        if c in p["effects"]:
            ideal = ideal_within(p["effects"][c][size_key], p["effects"][c][tau_key], p["duration_s"], seed=p["seed"])
            for key, v in zip((size_key, tau_key), ideal):
                if f"{c}.{key}" in errors:
                    errors[f"{c}.{key}"]["ideal"] = v


def oddity_rise_db(p: dict, flight, nominal_snr_db: float) -> dict | None:
    """What a second scatterer leaves for the goodness of fit to see: the flight
    remade without it (same plan, same nominal SNR; the emulator's is the same
    realisation, the independent generator's draws its noise anew), both read in the
    goodness of fit's own bands (:func:`microdoppler.diagnosis.explain.band_power`,
    the diagnosis's body Doppler, guards and band width), mean power over the usable
    CPIs. Returns ``{"rise_db", "band_hz"}``: the largest rise [dB] over the bands
    the test reads and its body-relative band [Hz]. None for other effects or an
    undiagnosable flight.

    An effect that raises no band by the test's margin cannot be flagged without
    flagging explained flights whose model misfits by as much (the margin table)."""
    if "second_scatterer" not in p.get("oddities", {}):
        return None
    from microdoppler.diagnosis import Undiagnosable
    from microdoppler.diagnosis import pipeline as dp
    from microdoppler.diagnosis.config import DiagnosisConfig
    from microdoppler.diagnosis.explain import band_power
    from microdoppler.diagnosis.measure import stft_power

    cfg = DiagnosisConfig.from_dict({"figures": False})
    try:
        M = dp.measure(flight, None, cfg)
        T = dp.run_tests(M, cfg)
        g = dp.goodness_of_fit(flight, M, dp.decide_flight(M, T, cfg, started=0.0), cfg)
    except Undiagnosable:
        return None
    twin = _make({**p, "oddities": {}}, nominal_snr_db)
    other = stft_power(twin.iq, twin.prf_hz, cfg.cpi_pulses(twin.prf_hz))
    use = np.flatnonzero(M.valid)
    a = g["_band_args"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # bands the guards empty
        pw = np.nanmean([band_power(M.stft, i, M.f_body_hz[i], **a) for i in use], axis=0)
        po = np.nanmean([band_power(other, i, M.f_body_hz[i], **a) for i in use], axis=0)
    rise = 10 * np.log10(pw / po)
    j = int(np.nanargmax(rise))
    c = (j - a["n_side"]) * a["bw"]
    return {"rise_db": round(float(rise[j]), 2), "band_hz": [round(c - a["bw"] / 2, 1), round(c + a["bw"] / 2, 1)]}


def evaluate_flight(p: dict, store_dir: str | None = None) -> dict:
    """Make the planned flight at its target SNR, diagnose it, compare with its truth.

    ``store_dir``: write the flight there as ``{flight_id}.zarr`` if it enters the
    paired comparison (:func:`is_paired`), and diagnose the store as read back (the
    bytes the older code will see)."""
    t0 = time.perf_counter()
    target = p["target_snr_db"]
    nominal = target + (3.0 if p["generator"] == "emulator" else 1.0)
    tries = []
    for _ in range(3):
        flight = _make(p, nominal)
        snr = _snr_db(flight)
        tries.append([round(nominal, 2), round(snr, 2)])
        if abs(snr - target) <= 2.0 and (snr >= HIGH_SNR_DB) == (target >= HIGH_SNR_DB):
            break
        nominal += target - snr + (0.5 if target >= HIGH_SNR_DB else -0.5)
    rise = _floor_rise_db(flight) if "phase_noise" in p["effects"] else None
    stored = bool(store_dir and is_paired(p))
    if stored:
        path = Path(store_dir) / f"{p['flight_id']}.zarr"
        write_flight(path, flight)
        flight = read_flight(path)
    t1 = time.perf_counter()
    named, fits, reason, gof = diagnose_with_fit(flight)  # sees the flight only
    t2 = time.perf_counter()
    errors = {}
    for c, truth in p["effects"].items():
        if c not in fits:
            continue
        for k, kind in PARAMS[c].items():
            if k not in fits[c]:
                errors[f"{c}.{k}"] = {"error": None, "ok": False, "truth": truth[k], "fit": None}
                continue
            err, ok = param_error(k, kind, truth[k], fits[c][k])
            errors[f"{c}.{k}"] = {"error": err, "ok": ok, "truth": truth[k], "fit": fits[c][k]}
    add_ideal(errors, p)
    odd_rise = oddity_rise_db(p, flight, tries[-1][0]) if p["kind"] == "outside" else None
    return {
        **{k: p[k] for k in ("flight_id", "kind", "generator", "radar", "drone_model", "effects", "duration_s")},
        "oddities": p.get("oddities", {}),
        "stored": stored,
        "harmonic_falloff_db": p.get("harmonic_falloff_db"),
        "true": sorted(p["effects"]),
        "named": named,
        "fits": fits,
        "reason": reason,
        "gof": gof,
        "snr_db": round(snr, 2),
        "target_snr_db": round(target, 2),
        "snr_tries": tries,
        "pn_floor_rise_db": None if rise is None else round(rise, 2),
        "oddity_rise": odd_rise,
        "errors": errors,
        "seconds_make": round(t1 - t0, 2),
        "seconds_diagnose": round(t2 - t1, 2),
    }


# ----------------------------------------------------------------------------- summaries
def _fmt(v, lo, hi, pct=True):
    if not np.isfinite(v):
        return "–"
    if pct:
        return f"{100 * v:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}]"
    return f"{v:.3g} [{lo:.3g}, {hi:.3g}]"


class Summary:
    """Ratios of flight sums with flight-bootstrap CIs over a fixed set of draws."""

    def __init__(self, rows: list[dict], seed: int, n_boot: int):
        self.rows = rows
        strata = [r["kind"] if r["kind"] != "one" else f"one:{r['true'][0]}" for r in rows]
        self.draws = draw_flights([r["flight_id"] for r in rows], strata=strata, n_boot=n_boot, seed=seed)

    def ratio(self, num, den) -> tuple[float, float, float, int]:
        """(point, lo, hi, denominator) of sum(num) / sum(den) over flights."""
        num, den = np.asarray(num, float), np.asarray(den, float)
        d = den.sum()
        if d == 0:
            return float("nan"), float("nan"), float("nan"), 0
        lo, hi = interval(ratio_replicates(num, den, self.draws))
        return float(num.sum() / d), lo, hi, int(round(d))

    def median_abs(self, vals, mask) -> tuple[float, float, float]:
        """Median |value| over the flights in ``mask``, with a flight-bootstrap CI."""
        idx = np.flatnonzero(mask)
        if len(idx) == 0:
            return float("nan"), float("nan"), float("nan")
        v = np.abs(np.asarray(vals, float)[idx])
        o = np.argsort(v)
        v, w = v[o], self.draws.weights[:, idx[o]]
        cum = np.cumsum(w, axis=1)
        tot = cum[:, -1:]
        pos = np.argmax(cum >= tot / 2, axis=1).astype(float)
        reps = np.where(tot[:, 0] > 0, v[pos.astype(int)], np.nan)
        lo, hi = interval(reps)
        return float(np.median(v)), lo, hi


def band_of(r) -> str:
    return "≥36" if r["snr_db"] >= HIGH_SNR_DB else "<36"


def _catalog_named(r) -> set:
    """The catalog causes a row names (``unexplained`` left out)."""
    return {c for c in r["named"] if c != UNEXPLAINED}


def summarise(rows: list[dict], boot_seed: int, n_boot: int) -> tuple[str, dict]:
    """Markdown tables and a JSON-able summary of the rows (catalog-cause and clean
    flights; ``unexplained`` is not counted as a spurious cause here)."""
    rows = [r for r in rows if r["kind"] != "outside"]
    S = Summary(rows, boot_seed, n_boot)
    band = np.array([band_of(r) for r in rows])
    gen = np.array([r["generator"] for r in rows])
    kind = np.array([r["kind"] for r in rows])
    subsets = [
        ("≥36", "all"),
        ("≥36", "emulator"),
        ("≥36", "independent"),
        ("<36", "all"),
        ("<36", "emulator"),
        ("<36", "independent"),
    ]

    def sel(b, g):
        return (band == b) & ((gen == g) if g != "all" else True)

    n_true = np.array([len(r["true"]) for r in rows])
    n_hit = np.array([len(set(r["true"]) & set(r["named"])) for r in rows])
    spur = np.array([bool(_catalog_named(r) - set(r["true"])) for r in rows])
    n_spur = np.array([len(_catalog_named(r) - set(r["true"])) for r in rows])
    n_named = np.array([len(_catalog_named(r)) for r in rows])
    skipped = np.array([r["reason"] is not None for r in rows])
    out: dict = {"overall": {}, "per_cause": {}, "params": {}, "snr_bins": {}}
    lines = [
        "### Detection (95 % flight-bootstrap CIs)",
        "",
        "| SNR | generator | flights | true causes named | spurious, two-cause flights (flights) | "
        "spurious, two-cause flights (share of named causes) | spurious, one-cause flights | "
        "false alarms, clean flights | skipped |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for b, g in subsets:
        m = sel(b, g)
        rec = S.ratio(n_hit * m, n_true * m)
        sp2 = S.ratio(spur * m * (kind == "two"), m * (kind == "two"))
        sp2n = S.ratio(n_spur * m * (kind == "two"), n_named * m * (kind == "two"))
        sp1 = S.ratio(spur * m * (kind == "one"), m * (kind == "one"))
        fa = S.ratio(spur * m * (kind == "clean"), m * (kind == "clean"))
        out["overall"][f"{b} {g}"] = {
            "flights": int(m.sum()),
            "recall": rec,
            "spurious_two": sp2,
            "spurious_two_of_named": sp2n,
            "spurious_one": sp1,
            "false_alarm": fa,
            "skipped": int((skipped & m).sum()),
        }
        lines.append(
            f"| {b} dB | {g} | {int(m.sum())} | {_fmt(*rec[:3])} ({int(n_hit[m].sum())}/{rec[3]}) | "
            f"{_fmt(*sp2[:3])} ({int((spur * m * (kind == 'two')).sum())}/{sp2[3]}) | "
            f"{_fmt(*sp2n[:3])} ({int((n_spur * m * (kind == 'two')).sum())}/{sp2n[3]}) | "
            f"{_fmt(*sp1[:3])} ({int((spur * m * (kind == 'one')).sum())}/{sp1[3]}) | "
            f"{_fmt(*fa[:3])} ({int((spur * m * (kind == 'clean')).sum())}/{fa[3]}) | "
            f"{int((skipped & m).sum())} |"
        )
    radar = np.array([r["radar"] for r in rows])
    lines += [
        "",
        "### By radar",
        "",
        "| radar | SNR | flights | true causes named | false alarms, clean | spurious, one- and two-cause flights |",
        "|---|---|---|---|---|---|",
    ]
    for rd in ("radar1", "radar2", "gen_l", "gen_s"):
        for b in ("≥36", "<36"):
            m = (radar == rd) & (band == b)
            rec = S.ratio(n_hit * m, n_true * m)
            fa = S.ratio(spur * m * (kind == "clean"), m * (kind == "clean"))
            sp = S.ratio(spur * m * (kind != "clean"), m * (kind != "clean"))
            out["overall"][f"{b} {rd}"] = {"flights": int(m.sum()), "recall": rec, "false_alarm": fa, "spurious": sp}
            lines.append(
                f"| {rd} | {b} dB | {int(m.sum())} | {_fmt(*rec[:3])} ({int(n_hit[m].sum())}/{rec[3]}) | "
                f"{_fmt(*fa[:3])} ({int((spur * m * (kind == 'clean')).sum())}/{fa[3]}) | "
                f"{_fmt(*sp[:3])} ({int((spur * m * (kind != 'clean')).sum())}/{sp[3]}) |"
            )
    lines += [
        "",
        "### Per cause: recall and precision",
        "",
        "| cause | recall ≥36 all | recall ≥36 emulator | recall ≥36 independent | precision ≥36 | "
        "recall <36 all | precision <36 |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in CAUSE_LIST:
        has = np.array([c in r["true"] for r in rows])
        got = np.array([c in r["named"] for r in rows])
        cells, res = [], {}
        for key, m, num, den in [
            ("recall ≥36 all", sel("≥36", "all"), has & got, has),
            ("recall ≥36 emulator", sel("≥36", "emulator"), has & got, has),
            ("recall ≥36 independent", sel("≥36", "independent"), has & got, has),
            ("precision ≥36", sel("≥36", "all"), has & got, got),
            ("recall <36 all", sel("<36", "all"), has & got, has),
            ("precision <36", sel("<36", "all"), has & got, got),
        ]:
            v = S.ratio(num * m, den * m)
            res[key] = v
            cells.append(f"{_fmt(*v[:3])} ({int((num * m).sum())}/{v[3]})")
        out["per_cause"][c] = res
        lines.append(f"| {c} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "### Canonical parameters of named true causes",
        "error: absolute for asymmetry_db [dB] and lag_s [s], else relative (scale: of scale - 1; "
        "skirt_dbc_hz: of the linear density); target 20 % / 1 dB / 0.1 s",
        "",
        "| parameter | SNR | generator | n | median abs error | within target | median signed error |",
        "|---|---|---|---|---|---|---|",
    ]
    for c, ps in PARAMS.items():
        for k in ps:
            key = f"{c}.{k}"
            err = np.array(
                [
                    r["errors"][key]["error"]
                    if key in r["errors"] and r["errors"][key]["error"] is not None
                    else np.nan
                    for r in rows
                ]
            )
            has = np.array([key in r["errors"] for r in rows])
            ok = np.array([key in r["errors"] and r["errors"][key]["ok"] for r in rows])
            for b, g in subsets:
                m = sel(b, g) & has
                if not m.any():
                    continue
                med = S.median_abs(np.nan_to_num(err, nan=np.inf), m)
                w = S.ratio(ok * m, m)
                signed = float(np.nanmedian(err[m])) if np.isfinite(err[m]).any() else float("nan")
                ideal = np.array(
                    [r["errors"][key].get("ideal", np.nan) if key in r["errors"] else np.nan for r in rows]
                )
                im = m & np.isfinite(ideal)
                ideal_w = S.ratio(np.nan_to_num(ideal) * im, im) if im.any() else None
                ideal_d = S.ratio((ok - np.nan_to_num(ideal)) * im, im) if im.any() else None
                out["params"][f"{key} {b} {g}"] = {
                    "n": int(m.sum()),
                    "median_abs": med,
                    "within": w,
                    "median_signed": signed,
                    "ideal": ideal_w,
                    "minus_ideal": ideal_d,
                    "max_abs": float(np.max(np.abs(np.nan_to_num(err[m], nan=np.inf)))),
                }
                pct = ps[k] != "abs"
                medtxt = (
                    f"{100 * med[0]:.0f} % [{100 * med[1]:.0f}, {100 * med[2]:.0f}]" if pct else _fmt(*med, pct=False)
                )
                sg = f"{100 * signed:+.0f} %" if pct else f"{signed:+.3g}"
                lines.append(f"| {key} | {b} | {g} | {int(m.sum())} | {medtxt} | {_fmt(*w[:3])} | {sg} |")
    lines += [
        "",
        "### Recall per cause in bins of measured body SNR (named/true)",
        "",
        "| cause | " + " | ".join(_bin_name(i) for i in range(len(SNR_BINS_DB) - 1)) + " | recall ≥ 90 % from |",
        "|---|" + "---|" * (len(SNR_BINS_DB)),
    ]
    snr = np.array([r["snr_db"] for r in rows])
    for c in CAUSE_LIST:
        cells, recs = [], []
        for i in range(len(SNR_BINS_DB) - 1):
            m = (snr >= SNR_BINS_DB[i]) & (snr < SNR_BINS_DB[i + 1]) if i else (snr < SNR_BINS_DB[1])
            has = np.array([c in r["true"] for r in rows]) & m
            hit = np.array([c in r["named"] for r in rows]) & has
            cells.append(f"{hit.sum()}/{has.sum()}" if has.sum() else "–")
            recs.append((hit.sum(), has.sum()))
        out["snr_bins"][c] = recs
        lines.append(f"| {c} | " + " | ".join(cells) + f" | {_detectable_from(recs)} |")
    pn = [r for r in rows if "phase_noise" in r["true"]]
    if pn:
        lines += [
            "",
            "Phase noise by floor rise 35-95 Hz from the clutter line (flight over background): "
            + ", ".join(
                f"{lab}: {sum('phase_noise' in r['named'] for r in sub)}/{len(sub)}"
                for lab, sub in [
                    ("rise < 3 dB", [r for r in pn if r["pn_floor_rise_db"] < 3]),
                    ("3-6 dB", [r for r in pn if 3 <= r["pn_floor_rise_db"] < 6]),
                    ("≥ 6 dB", [r for r in pn if r["pn_floor_rise_db"] >= 6]),
                ]
            ),
        ]
    return "\n".join(lines), out


def _bin_name(i: int) -> str:
    lo, hi = SNR_BINS_DB[i], SNR_BINS_DB[i + 1]
    if i == 0:
        return f"<{hi:g} dB"
    return f"≥{lo:g} dB" if not np.isfinite(hi) else f"{lo:g}-{hi:g} dB"


def _detectable_from(recs) -> str:
    """Lowest bin edge from which every bin with flights has recall >= 90 %."""
    edge = None
    for i in range(len(recs) - 1, -1, -1):
        hit, n = recs[i]
        if n == 0:
            continue
        if hit / n >= 0.9:
            edge = i
        else:
            break
    if edge is None:
        return "nowhere"
    return "every bin (from ~20 dB)" if edge == 0 else f"{SNR_BINS_DB[edge]:g} dB"


def targets(out: dict) -> str:
    """Pass/fail of the issue's targets at body SNR >= 36 dB, on the point estimates
    (the CI says how sure that is)."""
    o = out["overall"]["≥36 all"]
    lines = [
        "### Targets at body SNR ≥ 36 dB (pass/fail on the point estimate)",
        "",
        "| target | value [95 % CI] | pass |",
        "|---|---|---|",
    ]
    for name, v, ok in [
        ("≥ 90 % of true causes named", o["recall"], o["recall"][0] >= 0.9),
        (
            "≤ 5 % spurious causes (two-cause flights naming a cause they lack)",
            o["spurious_two"],
            o["spurious_two"][0] <= 0.05,
        ),
        ("≤ 5 % false alarms (clean flights naming any cause)", o["false_alarm"], o["false_alarm"][0] <= 0.05),
    ]:
        lines.append(f"| {name} | {_fmt(*v[:3])} (n={v[3]}) | {'PASS' if ok else 'FAIL'} |")
    lines += [
        "",
        "Canonical parameters within 20 % (asymmetry 1 dB, lag 0.1 s), of the named true causes at "
        "≥ 36 dB: strict = every estimate, or >= 90 % of them",
        "",
        "| parameter | n | within target [95 % CI] | largest abs error | strict | ≥ 90 % | ideal observer, "
        "same flights | ours − ideal [95 % CI] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for c, ps in PARAMS.items():
        for k, kind in ps.items():
            v = out["params"].get(f"{c}.{k} ≥36 all")
            if v is None:
                lines.append(f"| {c}.{k} | 0 | no estimate | – | – | – |")
                continue
            w = v["within"]
            mx = f"{100 * v['max_abs']:.0f} %" if kind != "abs" else f"{v['max_abs']:.3g}"
            idl, dif = v.get("ideal"), v.get("minus_ideal")
            idl_txt = f"{100 * idl[0]:.0f} %" if idl else "–"
            dif_txt = f"{100 * dif[0]:+.0f} [{100 * dif[1]:+.0f}, {100 * dif[2]:+.0f}] points" if dif else "–"
            lines.append(
                f"| {c}.{k} | {w[3]} | {_fmt(*w[:3])} | {mx} | {'PASS' if w[0] == 1.0 else 'FAIL'} | "
                f"{'PASS' if w[0] >= 0.9 else 'FAIL'} | {idl_txt} | {dif_txt} |"
            )
    lines += [
        "",
        "Ideal observer: the share of the same flights' true (size, timescale) an exact AR(1) fit "
        "to the noise-free process itself gets within 20 % (`ideal_within`); no estimator from "
        "spectrograms can beat it, so a per-estimate target above it is out of reach at this flight length.",
    ]
    return "\n".join(lines)


def _cell(v, k=None) -> str:
    """``x % [lo, hi] (k/n)`` of a :meth:`Summary.ratio` result."""
    if v[3] == 0:
        return "– (0)"
    kk = f"{k}/{v[3]}" if k is not None else f"n={v[3]}"
    return f"{_fmt(*v[:3])} ({kk})"


def _diff_cell(v) -> str:
    if v[3] == 0 or not np.isfinite(v[0]):
        return "–"
    res = " resolved" if resolved(v[1], v[2]) else ""
    return f"{100 * v[0]:+.0f} [{100 * v[1]:+.0f}, {100 * v[2]:+.0f}] points{res}"


def issue34_flags(rows: list[dict]) -> dict:
    """Per-row boolean arrays of issue 34's rates."""
    kind = np.array([r["kind"] for r in rows])
    err = [r["errors"].get("blade_imbalance.imbalance_db") for r in rows]
    f = {
        "has_imb": np.array(["blade_imbalance" in r["true"] for r in rows]),
        "named_imb": np.array(["blade_imbalance" in r["named"] for r in rows]),
        "imb_ok": np.array([bool(e and e["ok"]) for e in err]),
        "unexpl": np.array([UNEXPLAINED in r["named"] for r in rows]),
        "skipped": np.array([r["reason"] is not None for r in rows]),
        "outside": kind == "outside",
        "catalog_only": np.isin(kind, ("one", "two", "clean")),
        "with_cause": np.isin(kind, ("one", "two")),
        "clean": kind == "clean",
    }
    f["none"] = np.array([r["reason"] is None and not r["named"] for r in rows])
    f["all_named"] = np.array([r["reason"] is None and set(r["true"]) <= set(r["named"]) for r in rows])
    f["balanced"] = f["catalog_only"] & ~f["has_imb"]
    # an effect the goodness of fit can resolve: every out-of-catalog effect but a
    # second scatterer that raises no band the test reads by its margin (oddity_rise_db)
    f["resolvable"] = f["outside"] & np.array(
        [not r.get("oddity_rise") or r["oddity_rise"]["rise_db"] >= r["gof"].get("margin_db", 7.0) for r in rows]
    )
    return f


#: issue 34's rates: (key, label, numerator, denominator) over :func:`issue34_flags`
ISSUE34_RATES = [
    (
        "imb_named",
        "blade_imbalance named, flights with a blade 3-10 dB weaker (target ≥ 90 %)",
        lambda f: f["named_imb"] & f["has_imb"],
        lambda f: f["has_imb"],
    ),
    (
        "imb_db_within",
        "imbalance_db within 1.5 dB, of those named",
        lambda f: f["imb_ok"] & f["named_imb"] & f["has_imb"],
        lambda f: f["named_imb"] & f["has_imb"],
    ),
    (
        "imb_spurious",
        "spurious blade_imbalance, balanced flights incl. other causes (target ≤ 5 %)",
        lambda f: f["named_imb"] & f["balanced"],
        lambda f: f["balanced"],
    ),
    (
        "unexpl_outside",
        "unexplained, out-of-catalog flights (target ≥ 90 %)",
        lambda f: f["unexpl"] & f["outside"],
        lambda f: f["outside"],
    ),
    (
        "none_outside",
        "none, out-of-catalog flights (must be 0)",
        lambda f: f["none"] & f["outside"],
        lambda f: f["outside"],
    ),
    (
        "none_outside_resolvable",
        "none, out-of-catalog flights whose effect raises a band the goodness of fit reads by ≥ its margin",
        lambda f: f["none"] & f["resolvable"],
        lambda f: f["resolvable"],
    ),
    (
        "skipped_outside",
        "skipped (undiagnosable), out-of-catalog flights",
        lambda f: f["skipped"] & f["outside"],
        lambda f: f["outside"],
    ),
    (
        "unexpl_catalog",
        "unexplained, flights holding only catalog causes (target ≤ 5 %)",
        lambda f: f["unexpl"] & f["catalog_only"],
        lambda f: f["catalog_only"],
    ),
    (
        "unexpl_with_cause",
        "unexplained, of those: one- and two-cause flights",
        lambda f: f["unexpl"] & f["with_cause"],
        lambda f: f["with_cause"],
    ),
    ("unexpl_clean", "unexplained, of those: clean flights", lambda f: f["unexpl"] & f["clean"], lambda f: f["clean"]),
    (
        "unexpl_all_named",
        "unexplained, of those: every true cause named (a missed cause left out)",
        lambda f: f["unexpl"] & f["catalog_only"] & f["all_named"],
        lambda f: f["catalog_only"] & f["all_named"],
    ),
]


#: goodness-of-fit margins [dB] the margin table reads
MARGINS_DB = (4, 5, 6, 7, 8, 9, 10, 12, 15)


def margin_table(rows: list[dict], f: dict, S, out: dict) -> list[str]:
    """Markdown lines: at body SNR >= 36 dB, the share of flights whose largest
    significant band residual (the goodness of fit's ``largest_significant_db``, any
    size) reaches each margin of :data:`MARGINS_DB`: flights holding only catalog
    causes, every true cause named (what the model should explain), and
    out-of-catalog flights (what it should not). The ``unexplained`` named for a
    power fluctuation common to body and blades does not depend on the margin and is
    not counted. Rows without the number (an older record) are left out."""
    has = np.array([bool(r.get("gof")) and "largest_significant_db" in r["gof"] for r in rows])
    if not has.any():
        return []
    big = np.array([r["gof"].get("largest_significant_db", 0.0) if r.get("gof") else 0.0 for r in rows])
    hi = np.array([band_of(r) == "≥36" for r in rows])
    groups = [
        ("catalog-only, every true cause named", f["catalog_only"] & f["all_named"] & has & hi),
        ("out-of-catalog", f["outside"] & has & hi),
    ]
    out["margin"] = {}
    lines = [
        "",
        "#### Goodness-of-fit margin: flights whose largest significant band residual reaches m dB "
        "(≥ 36 dB; 95 % flight-bootstrap CIs)",
        "",
        "| m [dB] | " + " | ".join(f"{g} (n={int(m.sum())})" for g, m in groups) + " |",
        "|---|" + "---|" * len(groups),
    ]
    for mdb in MARGINS_DB:
        cells = []
        for g, m in groups:
            v = S.ratio((big >= mdb) & m, m)
            out["margin"][f"{mdb} {g}"] = v
            cells.append(_cell(v, int(((big >= mdb) & m).sum())))
        lines.append(f"| {mdb} | " + " | ".join(cells) + " |")
    # the other path to unexplained: a sideband gain that follows the body's
    common = np.array([_common_gain_db(r) for r in rows], dtype=float)
    straddle = np.array([r["kind"] == "outside" and "range_straddle" in r["oddities"] for r in rows])
    lines += [
        "",
        "Unexplained for a sideband gain that follows the body's (a gain on the whole target; std [dB], ≥ 36 dB):",
        "",
    ]
    for g, m in [
        ("catalog-only flights", f["catalog_only"] & hi),
        ("out-of-catalog range straddles", straddle & hi),
        ("other out-of-catalog flights", f["outside"] & ~straddle & hi),
    ]:
        v = common[m & np.isfinite(common)]
        rng_txt = f", std {v.min():.2f}-{v.max():.2f} dB" if len(v) else ""
        out["margin"][f"common {g}"] = [int(len(v)), int(m.sum())]
        lines.append(f"- {g}: {len(v)} of {int(m.sum())}{rng_txt}")
    return lines


def below_margin(rows: list[dict], f: dict, out: dict) -> list[str]:
    """Markdown lines: the out-of-catalog flights (body SNR >= 36 dB) whose second
    scatterer raises no band the goodness of fit reads by its margin
    (:func:`oddity_rise_db`), each with the bound: the share of flights holding only
    catalog causes, every true cause named (>= 36 dB), whose largest significant band
    residual is at least that rise, i.e. the explained flights a margin low enough to
    flag it would call ``unexplained`` too."""
    hi = np.array([band_of(r) == "≥36" for r in rows])
    expl = np.array([r["gof"].get("largest_significant_db", np.nan) if r.get("gof") else np.nan for r in rows])
    base = f["catalog_only"] & f["all_named"] & hi & np.isfinite(expl)
    sub = [r for r, m in zip(rows, f["outside"] & ~f["resolvable"] & hi) if m]
    out["below_margin"] = []
    if not sub:
        return []
    lines = [
        "",
        "#### Out-of-catalog flights below the goodness of fit's reach (≥ 36 dB)",
        "",
        "The effect's largest rise over the same flight without it, in the bands the test reads; "
        "explained flights whose model misfits by at least as much (what a margin that low would "
        "also flag):",
        "",
    ]
    for r in sub:
        q = r["oddity_rise"]
        k = int(np.sum(base & (expl >= q["rise_db"])))
        n = int(base.sum())
        out["below_margin"].append(
            {"flight_id": r["flight_id"], **q, "named": r["named"], "explained_at_least": [k, n]}
        )
        lines.append(
            f"- {r['flight_id']} ({r['generator']}, {r['radar']}): +{q['rise_db']:.1f} dB in "
            f"{q['band_hz'][0]:+.0f}..{q['band_hz'][1]:+.0f} Hz from the body (margin "
            f"{r['gof'].get('margin_db', 7.0):.0f} dB); named {', '.join(r['named']) or 'none'}; "
            f"explained flights misfit by ≥ that: {k} of {n} ({100 * k / max(n, 1):.0f} %)"
        )
    return lines


def _common_gain_db(r: dict) -> float:
    """The std [dB] of the common gain that made row ``r`` unexplained (the report's
    ``excess_db`` over the whole analysed span), NaN otherwise."""
    u = r["fits"].get(UNEXPLAINED) or {}
    b = u.get("band_hz")
    return float(u["excess_db"]) if b and abs(b[0] + b[1]) < 1e-6 and u.get("excess_db") is not None else np.nan


def summarise_issue34(rows: list[dict], boot_seed: int, n_boot: int) -> tuple[str, dict]:
    """Issue 34's rates (:data:`ISSUE34_RATES`) per SNR band and generator, the
    out-of-catalog flights per effect, and the targets at body SNR >= 36 dB."""
    if not rows:
        return "", {}
    S = Summary(rows, boot_seed, n_boot)
    f = issue34_flags(rows)
    band = np.array([band_of(r) for r in rows])
    gen = np.array([r["generator"] for r in rows])
    cols = [("≥36", "all"), ("≥36", "emulator"), ("≥36", "independent"), ("<36", "all"), ("all", "all")]
    out: dict = {"rates": {}, "outside": {}, "imbalance_db_errors": {}}
    lines = [
        "### Issue 34: blade_imbalance and unexplained (95 % flight-bootstrap CIs)",
        "",
        "| rate | " + " | ".join(f"{b} dB {g}" if b != "all" else "all SNR" for b, g in cols) + " |",
        "|---|" + "---|" * len(cols),
    ]
    for key, label, num_f, den_f in ISSUE34_RATES:
        num, den = num_f(f), den_f(f)
        cells = []
        for b, g in cols:
            m = ((band == b) if b != "all" else True) & ((gen == g) if g != "all" else True)
            v = S.ratio(num & m, den & m)
            out["rates"][f"{key} {b} {g}"] = v
            cells.append(_cell(v, int((num & m).sum())))
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    # imbalance_db errors of the named
    err = np.array(
        [
            r["errors"]["blade_imbalance.imbalance_db"]["error"]
            if "blade_imbalance.imbalance_db" in r["errors"]
            and r["errors"]["blade_imbalance.imbalance_db"]["error"] is not None
            else np.nan
            for r in rows
        ]
    )
    for b in ("≥36", "<36"):
        m = (band == b) & np.isfinite(err)
        if m.any():
            out["imbalance_db_errors"][b] = {
                "n": int(m.sum()),
                "median_abs_db": float(np.median(np.abs(err[m]))),
                "max_abs_db": float(np.max(np.abs(err[m]))),
                "median_signed_db": float(np.median(err[m])),
            }
            lines.append(
                f"\nimbalance_db error (fit − truth) at {b} dB: n={int(m.sum())}, median |error| "
                f"{np.median(np.abs(err[m])):.2f} dB, largest {np.max(np.abs(err[m])):.2f} dB, "
                f"median signed {np.median(err[m]):+.2f} dB"
            )
    # the out-of-catalog flights per effect
    lines += [
        "",
        "#### Out-of-catalog flights per effect (all SNR; ≥ 36 dB in brackets)",
        "",
        "| effect | generator | flights | unexplained | none | skipped | catalog causes named |",
        "|---|---|---|---|---|---|---|",
    ]
    for g in ("independent", "emulator"):
        for eff in OUTSIDE[g]:
            sub = [r for r in rows if r["kind"] == "outside" and r["generator"] == g and eff in r["oddities"]]
            if not sub:
                continue
            hi = [r for r in sub if band_of(r) == "≥36"]

            def cnt(cond, rs):
                return sum(1 for r in rs if cond(r))

            conds = {
                "unexplained": lambda r: UNEXPLAINED in r["named"],
                "none": lambda r: r["reason"] is None and not r["named"],
                "skipped": lambda r: r["reason"] is not None,
            }
            named: dict = {}
            for r in sub:
                for c in _catalog_named(r):
                    named[c] = named.get(c, 0) + 1
            out["outside"][f"{eff} {g}"] = {
                "n": len(sub),
                "n_high": len(hi),
                **{k: [cnt(c, sub), cnt(c, hi)] for k, c in conds.items()},
                "catalog_named": named,
            }
            lines.append(
                f"| {eff} | {g} | {len(sub)} ({len(hi)}) | "
                + " | ".join(f"{cnt(c, sub)} ({cnt(c, hi)})" for c in conds.values())
                + f" | {', '.join(f'{k} {v}' for k, v in sorted(named.items())) or '–'} |"
            )
    lines += margin_table(rows, f, S, out)
    lines += below_margin(rows, f, out)
    # targets at >= 36 dB
    lines += [
        "",
        "#### Issue 34's targets at body SNR ≥ 36 dB (pass/fail on the point estimate)",
        "",
        "| target | value [95 % CI] (k/n) | pass |",
        "|---|---|---|",
    ]
    for key, label, test in [
        ("imb_named", "blade_imbalance named ≥ 90 %", lambda v: v >= 0.9),
        (
            "imb_db_within",
            "imbalance_db within 1.5 dB (share of those named; no threshold given, 90 % used)",
            lambda v: v >= 0.9,
        ),
        ("imb_spurious", "spurious blade_imbalance ≤ 5 %", lambda v: v <= 0.05),
        ("unexpl_outside", "unexplained on outside flights ≥ 90 %", lambda v: v >= 0.9),
        ("none_outside", "none on outside flights = 0", lambda v: v == 0),
        (
            "none_outside_resolvable",
            "none on outside flights = 0, of those whose effect reaches the margin",
            lambda v: v == 0,
        ),
        ("unexpl_catalog", "unexplained on catalog-only flights ≤ 5 %", lambda v: v <= 0.05),
    ]:
        v = out["rates"][f"{key} ≥36 all"]
        num = int(round(v[0] * v[3])) if v[3] else 0
        ok = "–" if v[3] == 0 else ("PASS" if test(v[0]) else "FAIL")
        out["rates"][f"{key} ≥36 all"] = v
        lines.append(f"| {label} | {_cell(v, num)} | {ok} |")
    return "\n".join(lines), out


def summarise_paired(rows: list[dict], before: dict, boot_seed: int, n_boot: int) -> tuple[str, dict]:
    """Before/after on the same stores (:func:`is_paired` flights diagnosed by both
    codes): recall per cause, all true causes, spurious catalog causes and skipped
    flights, before, after and after − before with flight-bootstrap CIs (flights drawn
    within their design group)."""
    P = [r for r in rows if r.get("stored") and r["flight_id"] in before]
    if not P:
        return "", {}
    S = Summary(P, boot_seed, n_boot)
    band = np.array([band_of(r) for r in P])
    B = [before[r["flight_id"]] for r in P]
    kind = np.array([r["kind"] for r in P])
    out: dict = {"flights": len(P), "per_cause": {}, "overall": {}}
    bands = [("≥36", band == "≥36"), ("<36", band == "<36"), ("all", np.ones(len(P), bool))]
    lines = [
        "### Before/after on the same stores (existing causes; 95 % flight-bootstrap CIs)",
        "",
        f"{len(P)} flights holding only catalog causes other than blade_imbalance (one-cause, two-cause, "
        "clean), each written once as a flight-zarr store and diagnosed by both codes. Resolved: the CI of "
        "after − before excludes 0.",
        "",
        "| cause | SNR | flights with it | recall before | recall after | after − before |",
        "|---|---|---|---|---|---|",
    ]
    for c in OLD_CAUSES:
        has = np.array([c in r["true"] for r in P])
        hit_a = np.array([c in r["named"] for r in P]) & has
        hit_b = np.array([c in b["named"] for b in B]) & has
        for bn, m in bands:
            if not (has & m).any():
                continue
            vb, va = S.ratio(hit_b & m, has & m), S.ratio(hit_a & m, has & m)
            d = S.ratio((hit_a.astype(float) - hit_b) * m, has & m)
            out["per_cause"][f"{c} {bn}"] = {"before": vb, "after": va, "diff": d}
            lines.append(
                f"| {c} | {bn} | {int((has & m).sum())} | {_cell(vb, int((hit_b & m).sum()))} | "
                f"{_cell(va, int((hit_a & m).sum()))} | {_diff_cell(d)} |"
            )
    n_true = np.array([len(r["true"]) for r in P])
    n_hit_a = np.array([len(set(r["true"]) & set(r["named"])) for r in P])
    n_hit_b = np.array([len(set(r["true"]) & set(b["named"])) for r, b in zip(P, B)])
    old = set(OLD_CAUSES)
    spur_b = np.array([bool((set(b["named"]) & old) - set(r["true"])) for r, b in zip(P, B)])
    spur_a = np.array([bool((_catalog_named(r) & old) - set(r["true"])) for r in P])
    spur_a_imb = np.array([bool(_catalog_named(r) - set(r["true"])) for r in P])
    skip_b = np.array([b["reason"] is not None for b in B])
    skip_a = np.array([r["reason"] is not None for r in P])
    unex_a = np.array([UNEXPLAINED in r["named"] for r in P])
    lines += ["", "| measure | SNR | n | before | after | after − before |", "|---|---|---|---|---|---|"]
    for label, key, nb, na, den in [
        ("true causes named (recall over all true causes)", "recall", n_hit_b, n_hit_a, n_true),
        (
            "flights naming a catalog cause they lack (the six earlier causes)",
            "spurious",
            spur_b,
            spur_a,
            np.ones(len(P)),
        ),
        (
            "… of those: two-cause flights",
            "spurious_two",
            spur_b * (kind == "two"),
            spur_a * (kind == "two"),
            kind == "two",
        ),
        (
            "… of those: clean flights (false alarms)",
            "false_alarm",
            spur_b * (kind == "clean"),
            spur_a * (kind == "clean"),
            kind == "clean",
        ),
        (
            "flights naming a catalog cause they lack, blade_imbalance counted (after only)",
            "spurious_any",
            spur_b,
            spur_a_imb,
            np.ones(len(P)),
        ),
        ("skipped (undiagnosable)", "skipped", skip_b, skip_a, np.ones(len(P))),
        ("unexplained (after only)", "unexplained", np.zeros(len(P)), unex_a, np.ones(len(P))),
    ]:
        for bn, m in bands:
            vb = S.ratio(np.asarray(nb, float) * m, np.asarray(den, float) * m)
            va = S.ratio(np.asarray(na, float) * m, np.asarray(den, float) * m)
            d = S.ratio((np.asarray(na, float) - np.asarray(nb, float)) * m, np.asarray(den, float) * m)
            out["overall"][f"{key} {bn}"] = {"before": vb, "after": va, "diff": d}
            lines.append(
                f"| {label} | {bn} | {vb[3]} | {_cell(vb, int(round(np.sum(np.asarray(nb) * m))))} | "
                f"{_cell(va, int(round(np.sum(np.asarray(na) * m))))} | {_diff_cell(d)} |"
            )
    # issue 34's known hole: phase noise with a sideband cause
    side = ("sideband_fading", "sideband_asymmetry")
    pn = [(r, b) for r, b in zip(P, B) if "phase_noise" in r["true"] and any(c in r["true"] for c in side)]
    if pn:
        sb = sum(any(c in b["named"] for c in side if c in r["true"]) for r, b in pn)
        sa = sum(any(c in r["named"] for c in side if c in r["true"]) for r, b in pn)
        out["pn_sideband"] = {"n": len(pn), "before": sb, "after": sa}
        lines.append(
            f"\nPhase noise with a sideband cause: the sideband cause named on {sb}/{len(pn)} flights "
            f"before, {sa}/{len(pn)} after."
        )
    return "\n".join(lines), out


def report(rows: list[dict], seed: int, n_boot: int, before: dict | None = None) -> tuple[str, dict]:
    """Every table: issue 34's rates and targets, the paired before/after (where
    ``before`` is given), then the earlier targets and tables."""
    text, out = summarise(rows, boot_seed=seed ^ 0x5EED, n_boot=n_boot)
    t34, out["issue34"] = summarise_issue34(rows, boot_seed=seed ^ 0x3434, n_boot=n_boot)
    parts = [t34]
    if before:
        tp, out["paired"] = summarise_paired(rows, before, boot_seed=seed ^ 0xBEF0, n_boot=n_boot)
        parts.append(tp)
    parts += [targets(out), text]
    return "\n\n".join(p for p in parts if p), out


def _rel(path) -> str:
    """A path as recorded: relative to the repository root where inside it, else
    its name (no paths of this machine in the records)."""
    if not path:
        return path
    p = Path(path).resolve()
    try:
        return str(p.relative_to(REPO))
    except ValueError:
        return p.name


def run_before(store_dir: str, before_src: str) -> tuple[dict, dict]:
    """Diagnose the stores with the code in ``before_src`` (a ``src/`` folder) in a
    subprocess; returns ({flight_id: result}, {"commit", "cpu_s", "wall_s"})."""
    out = Path(store_dir) / "_before.json"
    env = {**os.environ, "PYTHONPATH": str(Path(before_src).resolve()), "OMP_NUM_THREADS": "1"}
    t0, c0 = time.time(), os.times()
    subprocess.run(
        [sys.executable, str(Path(__file__).with_name("diagnose_stores.py")), store_dir, "--out", str(out)],
        env=env,
        check=True,
    )
    c1 = os.times()
    commit = subprocess.run(
        ["git", "-C", str(Path(before_src).resolve()), "rev-parse", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    info = {
        "commit": commit or None,
        "wall_s": round(time.time() - t0, 1),
        "cpu_s": round((c1.children_user - c0.children_user) + (c1.children_system - c0.children_system), 1),
    }
    return json.loads(out.read_text()), info


# ----------------------------------------------------------------------------- main
def resummarise(a) -> int:
    """Tables from an earlier run's rows (``--summarise``), adding the ideal-observer
    shares and the out-of-catalog effects' rise (:func:`oddity_rise_db`, the flight
    remade at its last nominal SNR) where the rows predate them."""
    data = json.loads(Path(a.summarise).read_text())
    rows, seed = data["rows"], data["seed"]
    plan = {
        p["flight_id"]: p
        for p in make_plan(
            seed,
            data["args"]["flights_per_cause"],
            data["args"]["two_cause"],
            data["args"]["clean"],
            data["args"]["duration_s"],
            data["args"]["high_snr_share"],
            data["args"].get("causes"),
            data["args"].get("falloff_db"),
            data["args"].get("generators", "both"),
            data["args"].get("outside", 0),
        )
    }
    for r in rows:
        p = plan[r["flight_id"]]
        r.setdefault("duration_s", p["duration_s"])
        r.setdefault("oddities", {})
        add_ideal(r["errors"], p)
        if r["kind"] == "outside" and "oddity_rise" not in r:
            nominal = r["snr_tries"][-1][0]
            r["oddity_rise"] = oddity_rise_db(p, _make(p, nominal), nominal)
    before = {r["flight_id"]: r["before"] for r in rows if r.get("before")}
    text, out = report(rows, seed, a.n_boot, before)
    print(text, flush=True)
    if a.json:  # the same record with this code's summary
        with atomic_file(a.json) as tmp:
            tmp.write_text(json.dumps({**data, "rows": rows, "summary": out}, indent=1, default=float))
    if a.markdown:
        with atomic_file(a.markdown) as tmp:
            tmp.write_text(text + "\n")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--flights-per-cause", type=int, default=10, help="one-cause flights per cause (default 10)")
    ap.add_argument("--two-cause", type=int, default=20, help="flights with two causes at once (default 20)")
    ap.add_argument("--clean", type=int, default=10, help="flights without an effect (default 10)")
    ap.add_argument(
        "--outside",
        type=int,
        default=0,
        help="flights with an out-of-catalog effect, half emulated and altered, half from the "
        "independent generator (default 0)",
    )
    ap.add_argument("--seed", type=int, default=None, help="seed of the plan (default: fresh random, printed)")
    ap.add_argument("--duration-s", type=float, default=40.0, help="flight duration [s] (default 40)")
    ap.add_argument(
        "--high-snr-share",
        type=float,
        default=0.6,
        help="share of flights with a target body SNR >= 36 dB (default 0.6)",
    )
    ap.add_argument(
        "--causes",
        type=lambda v: [c for c in v.split(",") if c],
        default=None,
        help="comma-separated catalog causes to restrict the one- and two-cause flights to "
        "(default: all); e.g. sideband_fading,body_fluctuation",
    )
    ap.add_argument(
        "--falloff-db",
        type=lambda v: tuple(float(x) for x in v.split(",")),
        default=None,
        metavar="LO,HI",
        help="draw the emulator flights' sideband fall-off per harmonic log-uniformly "
        "in LO-HI dB (default: the emulator's own draw, 4-16 dB); e.g. 10,16",
    )
    ap.add_argument(
        "--generators",
        choices=("both", "emulator", "independent"),
        default="both",
        help="which generator makes the flights (default both, alternating)",
    )
    ap.add_argument(
        "--json",
        default="",
        help="write the per-flight rows and the summary here (with --summarise: "
        "the earlier record with this code's summary)",
    )
    ap.add_argument("--markdown", default="", help="write the tables here")
    ap.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    ap.add_argument("--n-boot", type=int, default=2000, help="bootstrap replicates (default 2000)")
    ap.add_argument(
        "--summarise",
        default="",
        metavar="JSON",
        help="summarise the rows of an earlier run's --json file again (no flights are made)",
    )
    ap.add_argument(
        "--before-src",
        default="",
        metavar="DIR",
        help="the src/ folder of an older checkout: diagnose the catalog-cause flights' stores with it "
        "too, after the loop, and compare before/after on the same flights",
    )
    ap.add_argument(
        "--stores",
        default="",
        metavar="DIR",
        help="where the paired flights' flight-zarr stores go (default: a temporary folder, removed "
        "at the end); only with --before-src",
    )
    a = ap.parse_args(argv)
    if a.summarise:
        return resummarise(a)
    if a.stores and not a.before_src:
        ap.error("--stores needs --before-src")
    if a.before_src and not (Path(a.before_src) / "microdoppler" / "diagnosis").is_dir():
        ap.error(f"--before-src={a.before_src}: no microdoppler/diagnosis package there")
    for name in ("flights_per_cause", "two_cause", "clean", "outside"):
        if getattr(a, name) < 0:
            ap.error(f"--{name.replace('_', '-')}={getattr(a, name)} must be >= 0")
    if not a.duration_s >= 10:
        ap.error(f"--duration-s={a.duration_s} must be >= 10")
    if not 0 <= a.high_snr_share <= 1:
        ap.error(f"--high-snr-share={a.high_snr_share} must be in [0, 1]")
    if a.workers < 1:
        ap.error(f"--workers={a.workers} must be >= 1")
    if a.falloff_db is not None and not (len(a.falloff_db) == 2 and 0 < a.falloff_db[0] <= a.falloff_db[1]):
        ap.error(f"--falloff-db={a.falloff_db}: expected LO,HI with 0 < LO <= HI [dB]")
    unknown = sorted(set(a.causes or []) - set(CAUSE_LIST))
    if unknown:
        ap.error(f"--causes: {unknown} not in the catalog {CAUSE_LIST}")
    seed = a.seed if a.seed is not None else secrets.randbits(32)
    print(f"seed {seed} (rerun: --seed {seed})", flush=True)
    plan = make_plan(
        seed,
        a.flights_per_cause,
        a.two_cause,
        a.clean,
        a.duration_s,
        a.high_snr_share,
        a.causes,
        a.falloff_db,
        a.generators,
        a.outside,
    )
    n = len(plan)
    if n == 0:
        ap.error("no flights planned")
    n_paired = sum(is_paired(p) for p in plan) if a.before_src else 0
    est = (
        n * (EMU_S_PER_FLIGHT_S * a.duration_s * EMULATIONS_PER_FLIGHT + DIAG_S * a.duration_s)
        + n_paired * DIAG_BEFORE_S * a.duration_s
    ) / a.workers
    n_causes = len(a.causes) if a.causes else len(CAUSE_LIST)
    print(
        f"{n} flights ({a.flights_per_cause} per cause x {n_causes}, {a.two_cause} two-cause, "
        f"{a.clean} clean, {a.outside} outside; {n_paired} also diagnosed by the earlier code), "
        f"{a.duration_s:g} s each, {a.workers} worker(s): estimated {est / 60:.1f} min",
        flush=True,
    )
    tmp_stores = None
    store_dir = None
    if a.before_src:
        if a.stores:
            store_dir = a.stores
            Path(store_dir).mkdir(parents=True, exist_ok=True)
        else:
            tmp_stores = tempfile.TemporaryDirectory(prefix="eval_diagnosis_stores_")
            store_dir = tmp_stores.name
    t0 = time.time()
    c0 = os.times()
    rows = []
    work = partial(evaluate_flight, store_dir=store_dir)
    if a.workers == 1:
        it = map(work, plan)
    else:
        import multiprocessing as mp

        pool = mp.get_context("fork").Pool(a.workers)
        it = pool.imap_unordered(work, plan)
    for r in it:
        rows.append(r)
        el = time.time() - t0
        print(
            f"[{len(rows)}/{n} {el:.0f} s, eta {el / len(rows) * (n - len(rows)):.0f} s] {r['flight_id']} "
            f"{r['generator'][:3]} {r['radar']:6s} snr={r['snr_db']:5.1f} true={r['true']} named={r['named']} "
            f"{r['reason'] or ''} ({r['seconds_make']:.1f}+{r['seconds_diagnose']:.1f} s)",
            flush=True,
        )
    if a.workers > 1:
        pool.close()
        pool.join()
    rows.sort(key=lambda r: r["flight_id"])
    wall = time.time() - t0
    c1 = os.times()
    cpu = (
        (c1.user - c0.user)
        + (c1.system - c0.system)
        + (c1.children_user - c0.children_user)
        + (c1.children_system - c0.children_system)
    )
    before, before_info = {}, None
    if a.before_src:
        print(f"diagnosing {sum(r['stored'] for r in rows)} stores with the code in {a.before_src}", flush=True)
        before, before_info = run_before(store_dir, a.before_src)
        for r in rows:
            if r["flight_id"] in before:
                r["before"] = before[r["flight_id"]]
        if tmp_stores is not None:
            tmp_stores.cleanup()
    args = {**vars(a), **{k: _rel(getattr(a, k)) for k in ("json", "markdown", "stores", "before_src")}}
    if a.json:  # the rows first: a summary that fails loses nothing (--summarise rebuilds it)
        with atomic_file(a.json) as tmp:
            tmp.write_text(json.dumps({"seed": seed, "args": args, "rows": rows}, indent=1, default=float))
    text, out = report(rows, seed, a.n_boot, before)
    per = np.mean([r["seconds_make"] + r["seconds_diagnose"] for r in rows])
    footer = (
        f"\n{n} flights, seed {seed}, {a.duration_s:g} s each; wall {wall:.0f} s, CPU {cpu:.0f} s with "
        f"{a.workers} worker(s) ({per:.1f} s per flight: make {np.mean([r['seconds_make'] for r in rows]):.1f} s, "
        f"diagnose {np.mean([r['seconds_diagnose'] for r in rows]):.1f} s)"
    )
    if before_info:
        footer += (
            f"; the earlier code ({before_info['commit']}) on {len(before)} stores: wall "
            f"{before_info['wall_s']:.0f} s, CPU {before_info['cpu_s']:.0f} s"
        )
    reasons: dict = {}
    for r in rows:
        if r["reason"]:
            key = f"{r['reason'][:160]} ({'≥' if r['snr_db'] >= HIGH_SNR_DB else '<'}36 dB)"
            reasons[key] = reasons.get(key, 0) + 1
    footer += "".join(f"\n- {v} x {k}" for k, v in sorted(reasons.items()))
    print("\n" + text + "\n" + footer, flush=True)
    if a.json:
        with atomic_file(a.json) as tmp:
            tmp.write_text(
                json.dumps(
                    {
                        "seed": seed,
                        "args": args,
                        "rows": rows,
                        "summary": out,
                        "before": before_info,
                        "wall_s": round(wall, 1),
                        "cpu_s": round(cpu, 1),
                    },
                    indent=1,
                    default=float,
                )
            )
    if a.markdown:
        with atomic_file(a.markdown) as tmp:
            tmp.write_text(text + "\n" + footer + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
