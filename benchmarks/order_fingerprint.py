"""Fingerprint of the rotor order check (:func:`microdoppler.rotors.order.resolve_order`)
on a fixed set of seeded recordings (not run in CI).

The recordings come from the test suite's generators, which share no code with the
emulator: ``tests/any_radar.py`` (carriers 1.3-24 GHz, PRFs 2-20 kHz, hovering and
flying, 2 and 3 blades, equal or one weak blade; among them the seeds the order tests
and records name: the tip speed's prior deciding, an order plausible by its tip speed,
the rescue where the lines found no comb, rotors split between two rates),
``tests/independent_generator.py`` (its own radars; a weak blade, and three-blade
rotors declared as two: a wrong blade count) and ``tests/rotor_flights.py`` (the
paper's eq. (1)/(2)). Each is estimated as ``estimate_rotor_speeds`` does it, in two
parts: the speeds without the order check (``order=False``), then
:func:`~microdoppler.rotors.order.resolve_order` with a ``rerun`` that measures again at
the same CPI length (memoised: the same settings give the same estimate).

Prints, per recording, the chosen rate, the ratio to the lines, whether the order is
ambiguous and the error against the truth, then a sha256 of each recording's speeds,
their sigmas, ``info["order"]`` and ``info["method_diff_rev_s"]`` (JSON, sorted keys,
floats as ``repr``), and one of all; a second hash leaves ``info["order"]["settings"]``
out (the speeds and orders alone). Two versions of the code that print the same hash
resolve these recordings' orders alike, bit for bit.

Usage: ``OMP_NUM_THREADS=1 PYTHONPATH=src python benchmarks/order_fingerprint.py``
(a few minutes on one core; ``--only NAME ...`` for some recordings; ``--dump FILE``
writes what is hashed, to compare two versions recording by recording).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from any_radar import draw_case, make_recording, true_cpi_means  # noqa: E402
from independent_generator import GenCase, make_flight  # noqa: E402
from rotor_flights import PRF, cpi_truth, crowded_rotors, synthetic_flight  # noqa: E402

from microdoppler.rotors.order import resolve_order  # noqa: E402
from microdoppler.rotors.speed import RotorSpeedConfig, estimate_rotor_speeds  # noqa: E402

#: any_radar seeds (6 s) and what each covers (the generator's draws; tests and records)
ANY_SEEDS = {
    11007: "1.3 GHz, weak blade, the tip speed's prior decides (test_rotor_order)",
    9006: "9.4 GHz, 3 blades flying, the tip speed's prior decides (test_rotor_order)",
    19055: "1.3 GHz, 2.1 kHz, weak blade, plausible by its tip speed (test_rotor_order)",
    5045: "5.8 GHz, 2 kHz, flying, weak blade: no comb, rescued",
    13016: "9.4 GHz, 3 blades flying, weak blade: no comb, rescued",
    11041: "3.3 GHz, hover, 2 blades: rotors split between two rates",
    13013: "3.3 GHz, 2.8 kHz, 3 blades flying",
    11011: "3.3 GHz, 14.5 kHz, 2 blades flying",
    5016: "5.8 GHz, 3 blades hover, weak blade (8 dB)",
    21000: "1.3 GHz, 2 blades flying, weak blade (8.5 dB)",
    17041: "3.3 GHz, 3 blades hover, weak blade, at half the lines' rate",
    23018: "24 GHz, 10 kHz, 2 blades hover (folded)",
    19000: "1.3 GHz, 3 blades flying, weak blade, at 3x the lines' rate",
}


def _any(seed: int, **fixed):
    case = draw_case(seed, duration_s=6.0, **fixed)
    flight, truth = make_recording(case)

    def true_means(est):
        return true_cpi_means(truth, est.time_s, est.n_fft, flight.prf_hz).mean(axis=1)

    return case.name if not fixed else f"{case.name}-{fixed.get('n_blades', '')}b", flight, true_means


def _logged(flight):
    """Per-CPI truth from the flight's own motor log (the independent generator's)."""
    rev = np.asarray(flight.motors_rpm, float) / 60.0

    def true_means(est):
        return np.array([np.interp(est.time_s, flight.motors_time_s, rev[:, m]) for m in range(rev.shape[1])]).T.mean(
            axis=1
        )

    return true_means


def recordings(only=None):
    """(name, flight, true_means(est) -> per-CPI true mean speed [rev/s], note)."""
    for seed, note in ANY_SEEDS.items():
        if only and f"any{seed:04d}" not in only:
            continue
        name, flight, tm = _any(seed)
        yield name, flight, tm, note
    # the unequal blades (test_rotor_order): the lines read 1/B of the rate
    stand = dict(
        carrier_hz=1.3e9,
        prf_hz=5000.0,
        n_rotors=4,
        blade_length_m=0.2,
        tip_speed_mps=88.0,
        setup="hover",
        blade_to_body_db=0.0,
        body_snr_db=40.0,
        elevation_deg=5.0,
    )
    for seed, weak, nb in ((11, 6.0, 2), (13, 8.0, 3)):
        name = f"weak{seed}-{nb}b"
        if only and name not in only:
            continue
        case = draw_case(seed, duration_s=4.0, n_blades=nb, weak_blade_db=weak, **stand)
        flight, truth = make_recording(case)
        yield (
            name,
            flight,
            (lambda est, truth=truth, fl=flight: true_cpi_means(truth, est.time_s, est.n_fft, fl.prf_hz).mean(axis=1)),
            f"1.3 GHz, 5 kHz, {nb} blades hover, one {weak:g} dB weak: the lines read 1/{nb} of the rate",
        )
    gens = (
        ("gen-l-weak", GenCase("gen-l-weak", 71, "gen_l", {"blade_imbalance": {"imbalance_db": 6.0}}, 8.0)),
        ("gen-s", GenCase("gen-s", 72, "gen_s", {}, 8.0)),
        ("gen-2k-3b", GenCase("gen-2k-3b", 73, "gen_2k", {}, 12.0, oddities={"true_n_blades": 3})),
        ("gen-l-3b", GenCase("gen-l-3b", 74, "gen_l", {}, 8.0, oddities={"true_n_blades": 3})),
    )
    notes = {
        "gen-l-weak": "independent generator, 1.25 GHz, 6.5 kHz, one blade 6 dB weak",
        "gen-s": "independent generator, 2.9 GHz, 9 kHz",
        "gen-2k-3b": "independent generator, 1.25 GHz, 2 kHz: 3 blades declared 2 (wrong blade count)",
        "gen-l-3b": "independent generator, 1.25 GHz, 6.5 kHz: 3 blades declared 2 (wrong blade count)",
    }
    for name, gc in gens:
        if only and name not in only:
            continue
        flight, _ = make_flight(gc)
        yield name, flight, _logged(flight), notes[name]
    if not only or "paper-crowded" in only:
        rng = np.random.default_rng(75)
        t = np.arange(int(6 * PRF)) / PRF
        rev = crowded_rotors(rng, t)
        flight = synthetic_flight(rev, n_blades=3, blade_length_m=0.15, seed=75)
        yield (
            "paper-crowded",
            flight,
            (lambda est, rev=rev, t=t: cpi_truth(t, rev, est.time_s).mean(axis=1)),
            "paper's eq. (1)/(2), 1.35 GHz, 7.3 kHz, 3 blades, rotors within a bin or two",
        )


class Recording:
    """One recording's speeds without the order check, and the order under a config.

    ``resolve(ocfg)`` runs :func:`resolve_order` as ``estimate_rotor_speeds`` does (the
    re-measurements at the estimate's CPI length), memoising the re-measurements."""

    def __init__(self, name, flight, true_means, note, speed_config: RotorSpeedConfig | None = None):
        self.name, self.flight, self.true_means, self.note = name, flight, true_means, note
        self.cfg = speed_config or RotorSpeedConfig()
        self.lines = estimate_rotor_speeds(flight, config=self.cfg, order=False)
        self._memo = {}
        self.B = int(flight.attrs["n_blades"])

    def rerun(self, c, n_blades=None):
        n_blades = self.B if n_blades is None else n_blades
        key = (c, n_blades)
        if key not in self._memo:
            self._memo[key] = estimate_rotor_speeds(
                self.flight, n_fft=self.lines.n_fft, n_blades=n_blades, config=c, order=False
            )
        return replace(self._memo[key])  # resolve_order may change an estimate's info in place

    def resolve(self, ocfg=None):
        lines = replace(self.lines)
        lines.info = dict(lines.info)
        return resolve_order(self.flight, lines, self.cfg, rerun=self.rerun, config=ocfg)


def summary(rec: Recording, est) -> dict:
    """What the ablation compares: ok, chosen order, ambiguity, mean speed, error."""
    o = (est.info or {}).get("order") or {}
    if not est.ok or not est.valid.any():
        return {"ok": False, "ratio": None, "ambiguous": None, "mean_rev_s": None, "error": None}
    v = est.valid
    tm = rec.true_means(est)
    return {
        "ok": True,
        "ratio": o.get("ratio_to_lines"),
        "ambiguous": bool(o.get("ambiguous", False)),
        "mean_rev_s": float(np.median(est.common_rev_s[v])),
        "error": float(np.median(est.common_rev_s[v] / tm[v] - 1)),
    }


def _plain(x):
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return _plain(x.tolist())
    if isinstance(x, np.generic):
        return x.item()
    return x


def payload(est, settings: bool = True) -> dict:
    """What the hash covers: speeds, sigmas, ``info["order"]``, the method difference."""
    order = dict((est.info or {}).get("order") or {})
    if not settings:
        order.pop("settings", None)
    return _plain(
        {
            "ok": bool(est.ok),
            "reason": est.reason,
            "n_blades": int(est.n_blades),
            "n_fft": int(est.n_fft),
            "speeds_rev_s": np.asarray(est.speeds_rev_s, float),
            "speeds_std_rev_s": np.asarray(est.speeds_std_rev_s, float),
            "common_rev_s": np.asarray(est.common_rev_s, float),
            "common_std_rev_s": np.asarray(est.common_std_rev_s, float),
            "order": order,
            "method_diff_rev_s": (est.info or {}).get("method_diff_rev_s"),
        }
    )


def digest(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", help="recording names (default all)")
    ap.add_argument("--dump", help="also write what is hashed, per recording, to this JSON file")
    args = ap.parse_args(argv)
    hashes, bare, dumped = {}, {}, {}
    t_all = time.process_time()
    for name, flight, tm, note in recordings(args.only):
        t0 = time.process_time()
        rec = Recording(name, flight, tm, note)
        t1 = time.process_time()
        est = rec.resolve()
        t2 = time.process_time()
        s = summary(rec, est)
        dumped[name] = payload(est)
        hashes[name] = digest(dumped[name])
        bare[name] = digest(payload(est, settings=False))
        err = f"{100 * s['error']:+6.1f} %" if s["ok"] else "   -   "
        print(
            f"{name:14s} ratio {s['ratio']!s:7s} ambiguous {s['ambiguous']!s:5s} error {err} "
            f"[{t1 - t0:5.1f} + {t2 - t1:5.1f} s] {hashes[name][:12]}  {note}",
            flush=True,
        )
    print(f"cpu {time.process_time() - t_all:.0f} s")
    print(f"sha256 {digest(hashes)}")
    print(f"sha256 without settings {digest(bare)}")
    if args.dump:
        Path(args.dump).write_text(json.dumps(dumped, sort_keys=True, indent=1) + "\n")


if __name__ == "__main__":
    main()
