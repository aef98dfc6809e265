"""Profiles (``test``, ``default``, ``paper``) and writing a whole world.

- ``test``: 6 flights of 30-40 s (CI; seconds to emulate); the first Inspire's
  airframe has a 6 dB weak blade, the second a 4 dB sideband asymmetry.
- ``default``: 48 flights: 24 birds (10 single, 6 pairs, 5 small and 3 large flocks) of
  30-45 s, 9 Inspire, 8 Matrice, 7 Mini flights of 40-60 s (about 35 min of
  flight), both radars.
- ``paper``: Table III: 491 bird, 69 Inspire, 52 Matrice, 62 Mini flights with
  durations that give Table III's image counts per class (5814, 2183, 1899,
  1709 tiles of 20 timesteps), ~50:50 radars. Large: planned on demand.

Effects of the ``default`` and ``paper`` worlds (:func:`plan_effects`) have a
population structure: each Inspire/Matrice model has a systematic sideband asymmetry
(blade geometry; sign and size drawn once per world, |a| 3.5-5.5 dB, +-0.5 dB per
flight) that most of its flights show; per-flight effects (sideband fading, body
fluctuation, motor-log lag, motor-speed scale) come on top; >= 35 % of a model's
flights carry two effects and >= 15 % none. Every drone flight is flown by one of
:data:`AIRFRAMES_PER_MODEL` airframes of its model (:func:`plan_airframes`); a share
of each large model's airframes (:data:`IMBALANCED_SHARE`, at least one) carries an
unequal blade (``blade_imbalance``, imbalance_db uniform in :data:`IMBALANCE_DB`,
drawn once per airframe, :func:`world_airframes`) on every flight it flies, on top of
the flight's other effects. The key file records every flight's effects and airframe,
and the world's per-model systematic values and airframes (``population``).
Airframes come from streams of their own: the flights, their other effects and every
draw of a flight without an imbalance are those of a world without airframes.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from ..causes.catalog import CAUSES
from ..io.flightzarr import write_flight
from ..io.outputs import atomic_dir, atomic_file, commit_folder, is_tool_store
from ..spectra.spectrogram import SpectrogramConfig
from .drone import DYNAMICS
from .world import WEAK_BLADE_SHARE, FlightSpec, emulate_flight, measured_snr_db

PROFILES = ("test", "default", "paper")
PRF_HZ = 7300.0
#: Table III totals per class: (flights, images)
PAPER_COUNTS = {"bird": (491, 5814), "inspire2": (69, 2183), "matrice300": (52, 1899), "mini2": (62, 1709)}
PAPER_RADAR1 = {"bird": 0.5, "inspire2": 0.5, "matrice300": 0.55, "mini2": 0.4}


def _tile_duration_s(n_tiles: int, cfg=SpectrogramConfig()) -> float:
    """Shortest flight giving ``n_tiles`` tiles of ``cfg.tile_timesteps`` timesteps."""
    steps = n_tiles * cfg.tile_timesteps
    return (cfg.n_fft + (steps - 1) * cfg.hop) / PRF_HZ


def _drone_spec(fid, model, rng, seed, duration_s, radar_id, effects=None) -> FlightSpec:
    mini = model == "mini2"
    return FlightSpec(
        flight_id=fid,
        target="drone",
        drone_model=model,
        radar_id=radar_id,
        duration_s=float(duration_s),
        mean_range_m=float(rng.uniform(1000, 3000)),
        height_m=float(rng.choice([60.0, 80.0, 100.0])),
        speed_mps=float(rng.uniform(5, 10) if mini else rng.uniform(3, 12)),
        effects=effects or {},
        seed=int(seed),
        direction=int(rng.choice([1, -1])),
    )


def _bird_spec(fid, kind, rng, seed, duration_s, radar_id) -> FlightSpec:
    return FlightSpec(
        flight_id=fid,
        target="bird",
        bird_kind=kind,
        radar_id=radar_id,
        duration_s=float(duration_s),
        mean_range_m=float(rng.uniform(700, 2500)),
        height_m=float(rng.uniform(20, 120)),
        speed_mps=float(rng.uniform(5, 20)),
        seed=int(seed),
    )


#: drone models whose flights carry effects (the Mini has no motor log and its blades
#: sit below the noise: nothing a diagnosis could see)
EFFECT_MODELS = ("inspire2", "matrice300")
#: the systematic effect of every large model (blade geometry): its per-model size
#: abs(asymmetry_db) [dB], drawn once per world, and the per-flight jitter (uniform +-) [dB]
SYSTEMATIC_RANGE_DB = (3.5, 5.5)
SYSTEMATIC_JITTER_DB = 0.5
#: per-flight effects and the ranges their parameters are drawn from (catalog units;
#: uniform, except the body fluctuation's timescale_s, log-uniform; lag and scale
#: with a random sign)
PER_FLIGHT = {
    "sideband_fading": {"fading_std_db": (3.0, 6.0), "timescale_s": (1.0, 2.0)},
    "body_fluctuation": {"body_std_db": (3.0, 6.0), "timescale_s": (0.15, 1.0)},
    "motor_log_lag": {"lag_s": (0.3, 0.7)},
    "motor_speed_scale": {"scale": (0.05, 0.10)},
}
#: share of a model's flights with two effects, and with none (quotas, rounded up)
TWO_SHARE, CLEAN_SHARE = 0.35, 0.15
#: share of one-effect flights whose effect is the systematic one, and of two-effect
#: flights whose pair includes it (quotas, rounded up)
SYSTEMATIC_IN_ONE, SYSTEMATIC_IN_TWO = 0.7, 0.8


def world_population(seed: int) -> dict:
    """The per-model systematic effects of a world, deterministic in ``seed``.

    Returns ``{model: {"cause": "sideband_asymmetry", "asymmetry_db": a, "jitter_db": j}}``
    for each model of :data:`EFFECT_MODELS`: the sign and size of ``a`` are drawn once
    per world (|a| uniform in :data:`SYSTEMATIC_RANGE_DB`); every flight of the model
    that shows the effect carries a + uniform(-j, j).
    """
    rng = np.random.default_rng([int(seed) & 0xFFFFFFFF, 1001])
    pop = {}
    for model in EFFECT_MODELS:
        a = float(rng.choice([-1.0, 1.0]) * rng.uniform(*SYSTEMATIC_RANGE_DB))
        pop[model] = {"cause": "sideband_asymmetry", "asymmetry_db": round(a, 3), "jitter_db": SYSTEMATIC_JITTER_DB}
    return pop


#: airframes per drone model in a world (each drone flight is flown by one of them)
AIRFRAMES_PER_MODEL = 3
#: share of a large model's airframes (:data:`EFFECT_MODELS`) with an unequal blade
#: (rounded, at least one), and the range of its imbalance_db [dB] (uniform, drawn once
#: per airframe: a chipped, bent, repaired or differently pitched blade stays)
IMBALANCED_SHARE = 1.0 / 3.0
IMBALANCE_DB = (3.0, 10.0)


def world_airframes(seed: int) -> dict:
    """The airframes of a world and what each carries, deterministic in ``seed``.

    Returns ``{model: {airframe: effects}}`` for every drone model, airframes named
    ``{model}-A``, ``{model}-B``, ...; ``effects`` is ``{}`` or, for
    max(1, round(:data:`IMBALANCED_SHARE` n)) airframes of each model of
    :data:`EFFECT_MODELS` chosen at random, ``{"blade_imbalance": {"imbalance_db": x}}``
    with x uniform in :data:`IMBALANCE_DB`.
    """
    rng = np.random.default_rng([int(seed) & 0xFFFFFFFF, 1004])
    out = {}
    for model in DYNAMICS:
        names = [f"{model}-{chr(ord('A') + k)}" for k in range(AIRFRAMES_PER_MODEL)]
        frames: dict = {n: {} for n in names}
        if model in EFFECT_MODELS:
            n_imb = max(1, int(round(IMBALANCED_SHARE * len(names))))
            for j in sorted(rng.choice(len(names), size=n_imb, replace=False)):
                frames[names[j]] = {"blade_imbalance": {"imbalance_db": round(float(rng.uniform(*IMBALANCE_DB)), 3)}}
        out[model] = frames
    return out


def plan_airframes(models: list[str], seed: int) -> list[str]:
    """The airframe of each entry of ``models`` (drone model, or "" for a bird: "").

    Per drone model, its flights are dealt over the model's airframes
    (:func:`world_airframes` names) in a seeded random order, so every airframe flies
    floor(n / k) or ceil(n / k) of the model's n flights (each one at least one when
    n >= k)."""
    rng = np.random.default_rng([int(seed) & 0xFFFFFFFF, 1005])
    names = {m: list(f) for m, f in world_airframes(seed).items()}
    out = [""] * len(models)
    for model, frames in names.items():
        idx = [i for i, m in enumerate(models) if m == model]
        deal = rng.permutation(np.arange(len(idx)) % len(frames))
        for i, j in zip(idx, deal):
            out[i] = frames[int(j)]
    return out


def _per_flight_effect(rng, cause: str) -> dict:
    if cause == "motor_log_lag":
        return {"lag_s": round(float(rng.choice([-1.0, 1.0]) * rng.uniform(*PER_FLIGHT[cause]["lag_s"])), 3)}
    if cause == "motor_speed_scale":
        return {"scale": round(float(1.0 + rng.choice([-1.0, 1.0]) * rng.uniform(*PER_FLIGHT[cause]["scale"])), 4)}
    out = {}
    for k, r in PER_FLIGHT[cause].items():
        v = np.exp(rng.uniform(*np.log(r))) if (cause, k) == ("body_fluctuation", "timescale_s") else rng.uniform(*r)
        if k in {p.name for p in CAUSES[cause].params}:  # knobs the catalog has
            out[k] = round(float(v), 3)
    return out


def plan_effects(models: list[str], seed: int) -> list[dict]:
    """Effects of a world's flights (one dict per entry of ``models``, in order).

    Per drone model of :data:`EFFECT_MODELS`, the flights are shuffled (seeded) into
    quotas: ceil(:data:`TWO_SHARE` n) with two effects, ceil(:data:`CLEAN_SHARE` n)
    with none, the rest with one. Of the one-effect flights, ceil(:data:`SYSTEMATIC_IN_ONE`
    n_one) carry the model's systematic effect (:func:`world_population`), the others
    one per-flight effect; of the two-effect flights, ceil(:data:`SYSTEMATIC_IN_TWO`
    n_two) carry the systematic one and one per-flight effect, the others two distinct
    per-flight effects. Per-flight effects (:data:`PER_FLIGHT`) are drawn uniformly
    with parameters uniform in their ranges. Other models and birds: ``{}``.
    Everything derives from ``seed``.
    """
    pop = world_population(seed)
    rng = np.random.default_rng([int(seed) & 0xFFFFFFFF, 1002])
    out: list[dict] = [{} for _ in models]
    causes = list(PER_FLIGHT)
    for model in EFFECT_MODELS:
        idx = [i for i, m in enumerate(models) if m == model]
        n = len(idx)
        if n == 0:
            continue
        n_two, n_clean = int(np.ceil(TWO_SHARE * n)), int(np.ceil(CLEAN_SHARE * n))
        n_clean = min(n_clean, n - n_two)
        n_one = n - n_two - n_clean
        s_two, s_one = int(np.ceil(SYSTEMATIC_IN_TWO * n_two)), int(np.ceil(SYSTEMATIC_IN_ONE * n_one))
        plan = (
            [(2, True)] * s_two
            + [(2, False)] * (n_two - s_two)
            + [(1, True)] * s_one
            + [(1, False)] * (n_one - s_one)
            + [(0, False)] * n_clean
        )
        order = rng.permutation(n)
        sys_ = pop[model]
        for i, j in zip(idx, order):
            k, with_sys = plan[j]
            eff: dict = {}
            if with_sys:
                a = sys_["asymmetry_db"] + rng.uniform(-sys_["jitter_db"], sys_["jitter_db"])
                eff["sideband_asymmetry"] = {"asymmetry_db": round(float(a), 3)}
            n_own = int(k) - int(with_sys)
            for cause in rng.choice(causes, size=n_own, replace=False) if n_own else []:
                eff[str(cause)] = _per_flight_effect(rng, str(cause))
            out[i] = eff
    return out


def plan_world(profile: str, seed: int) -> list[FlightSpec]:
    """The flights of ``profile`` (``test``, ``default`` or ``paper``), deterministic in ``seed``."""
    if profile not in PROFILES:
        raise ValueError(f"profile={profile!r} must be one of {PROFILES}")
    rng = np.random.default_rng([int(seed) & 0xFFFFFFFF, 999])
    specs: list[FlightSpec] = []

    def nxt():
        return int(rng.integers(2**31))

    if profile == "test":
        plan = [
            ("drone", "inspire2", "radar1", 36.0),
            ("drone", "matrice300", "radar2", 36.0),
            ("drone", "inspire2", "radar2", 32.0),
            ("drone", "mini2", "radar1", 32.0),
            ("bird", "single", "radar1", 32.0),
            ("bird", "small_flock", "radar2", 32.0),
        ]
        for i, (tg, what, rid, dur) in enumerate(plan):
            fid = f"t{i:02d}_{what}"
            if tg == "drone":
                eff = {"sideband_asymmetry": {"asymmetry_db": 4.0}} if i == 2 else {}
                if i == 0:  # an airframe with a weak blade (the rest of the flight as before)
                    eff = {"blade_imbalance": {"imbalance_db": 6.0}}
                specs.append(replace(_drone_spec(fid, what, rng, nxt(), dur, rid, eff), airframe=f"{what}-A"))
            else:
                specs.append(_bird_spec(fid, what, rng, nxt(), dur, rid))
        return [replace(s, site_seed=int(seed)) for s in specs]
    if profile == "default":
        classes = (
            [("bird", k) for k in ["single"] * 10 + ["pair"] * 6 + ["small_flock"] * 5 + ["large_flock"] * 3]
            + [("drone", "inspire2")] * 9
            + [("drone", "matrice300")] * 8
            + [("drone", "mini2")] * 7
        )
        for i, (tg, what) in enumerate(classes):
            rid = "radar1" if i % 2 == 0 else "radar2"
            if tg == "bird":
                specs.append(_bird_spec(f"d{i:03d}_bird", what, rng, nxt(), rng.uniform(30, 45), rid))
            else:
                specs.append(_drone_spec(f"d{i:03d}_{what}", what, rng, nxt(), rng.uniform(40, 60), rid))
        return _with_effects(specs, seed)
    # paper
    kinds = ["single"] * 50 + ["pair"] * 25 + ["small_flock"] * 17 + ["large_flock"] * 8
    i = 0
    for cls, (n_fl, n_img) in PAPER_COUNTS.items():
        tiles = np.full(n_fl, n_img // n_fl)
        tiles[: n_img - tiles.sum()] += 1
        rng.shuffle(tiles)
        # spread the tile counts (shorter and longer flights), keeping the total
        spread = rng.integers(-(tiles.min() - 1) // 2, (tiles.min() - 1) // 2 + 1, n_fl)
        spread -= int(np.round(spread.mean()))
        tiles = np.maximum(1, tiles + spread)
        tiles[-1] = max(1, tiles[-1] + n_img - tiles.sum())
        for k in range(n_fl):
            dur = _tile_duration_s(int(tiles[k])) + rng.uniform(0, 1.0)
            rid = "radar1" if rng.uniform() < PAPER_RADAR1[cls] else "radar2"
            fid = f"p{i:04d}_{cls}"
            if cls == "bird":
                specs.append(_bird_spec(fid, kinds[int(rng.integers(len(kinds)))], rng, nxt(), dur, rid))
            else:
                specs.append(_drone_spec(fid, cls, rng, nxt(), dur, rid))
            i += 1
    return _with_effects(specs, seed)


def _with_effects(specs: list[FlightSpec], seed: int) -> list[FlightSpec]:
    """``specs`` with the world's site seed, the effects of :func:`plan_effects`, weak
    blades on :data:`~.world.WEAK_BLADE_SHARE` of the large drones (own stream) and
    each drone's airframe (:func:`plan_airframes`) with what it carries
    (:func:`world_airframes`, after the flight's own effects)."""
    models = [s.drone_model if s.target == "drone" else "" for s in specs]
    effects = plan_effects(models, seed)
    weak = np.random.default_rng([int(seed) & 0xFFFFFFFF, 1003]).uniform(size=len(specs)) < WEAK_BLADE_SHARE
    frames = world_airframes(seed)
    flown = plan_airframes(models, seed)
    return [
        replace(
            s,
            site_seed=int(seed),
            effects={**e, **(frames[m][a] if a else {})},
            weak_blades=bool(w and s.drone_model in EFFECT_MODELS),
            airframe=a,
        )
        for s, e, w, m, a in zip(specs, effects, weak, models, flown)
    ]


def population_key(seed: int) -> dict:
    """The ``population`` section of the key: per-model systematic effects
    (:func:`world_population`), the per-flight effects' ranges and the quotas."""
    return {
        "systematic": world_population(seed),
        "airframes": world_airframes(seed),
        "airframes_per_model": AIRFRAMES_PER_MODEL,
        "imbalanced_share": IMBALANCED_SHARE,
        "imbalance_db_range": list(IMBALANCE_DB),
        "per_flight": {c: {k: list(r) for k, r in p.items()} for c, p in PER_FLIGHT.items()},
        "signed": {"motor_log_lag": "lag_s = +-U(range)", "motor_speed_scale": "scale = 1 +- U(range)"},
        "two_effects_share_min": TWO_SHARE,
        "clean_share_min": CLEAN_SHARE,
        "systematic_in_one": SYSTEMATIC_IN_ONE,
        "systematic_in_two": SYSTEMATIC_IN_TWO,
    }


def _systematic(spec: FlightSpec, pop: dict) -> list[str]:
    """The flight's effects that are its model's systematic ones."""
    sys_ = pop.get("systematic", {}).get(spec.drone_model) if spec.target == "drone" else None
    return [sys_["cause"]] if sys_ and sys_["cause"] in dict(spec.effects) else []


def _airframe_effects(spec: FlightSpec, pop: dict) -> list[str]:
    """The flight's effects that its airframe carries (``blade_imbalance``)."""
    frame = pop.get("airframes", {}).get(spec.drone_model, {}).get(spec.airframe, {})
    return [c for c in frame if c in dict(spec.effects)]


def _spec_json(spec: FlightSpec) -> dict:
    d = asdict(spec)
    d["effects"] = {k: dict(v) for k, v in dict(spec.effects).items()}
    return d


def _emulate_one(spec: FlightSpec, out_dir: str) -> dict:
    t0 = time.perf_counter()
    flight, truth = emulate_flight(spec)
    write_flight(Path(out_dir) / f"{spec.flight_id}.zarr", flight)
    snr_mean, snr_std = measured_snr_db(flight)
    log_rel = ""
    if flight.has_motor_log:
        log_rel = f"motor_logs/{spec.flight_id}.csv"
        with atomic_file(Path(out_dir) / log_rel) as tmp, open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["time_s"] + [f"motor{m + 1}_rpm" for m in range(flight.motors_rpm.shape[1])])
            for ti, row in zip(flight.motors_time_s, flight.motors_rpm):
                w.writerow([f"{ti:.4f}"] + [f"{v:.0f}" for v in row])
    return {
        "spec": spec,
        "truth": truth,
        "snr_mean": snr_mean,
        "snr_std": snr_std,
        "log": log_rel,
        "mean_range_m": float(np.mean(flight.track_range_m)),
        "seconds": time.perf_counter() - t0,
        "duration_s": flight.duration_s,
    }


def emulate_world(
    profile: str,
    seed: int,
    out_dir,
    *,
    key_path=None,
    progress: bool = True,
    workers: int | None = None,
    specs: list[FlightSpec] | None = None,
) -> list[dict]:
    """Emulate every flight of ``profile`` into ``out_dir``.

    Writes ``{flight_id}.zarr`` (flight-zarr/1), ``flights.csv`` (flight_id, target,
    drone_model, bird_kind, radar_id, duration_s, mean_range_m, mean_snr_db),
    ``motor_logs/{flight_id}.csv`` (time_s + one rpm column per motor),
    ``motor_logs.tsv`` (flight_id, motor_log, format, unit, time_offset_s) and, with
    ``key_path``, the key (effects and truth per flight; never read downstream).
    ``specs`` overrides the plan (e.g. a subsample of the paper profile).
    """
    final = Path(out_dir)
    specs = plan_world(profile, seed) if specs is None else list(specs)
    workers = workers or min(2, os.cpu_count() or 1)
    out = atomic_dir(final)  # written beside, renamed in when complete
    out.mkdir()
    try:
        rows, results, wall = _emulate_into(out, specs, progress, workers)
        commit_folder(out, final, is_world_entry)
    finally:
        if out.exists():
            shutil.rmtree(out, ignore_errors=True)
    flown = sum(r["duration_s"] for r in results)
    if key_path is not None:
        pop = population_key(seed) if profile != "test" else {}
        key = {
            "schema": "emulator-key/1",
            "profile": profile,
            "seed": int(seed),
            "note": "hidden truth of the emulated world; never read downstream",
            "population": pop,
            "flights": {
                r["spec"].flight_id: {
                    "effects": r["truth"]["effects"],
                    "systematic": _systematic(r["spec"], pop),
                    "airframe": r["spec"].airframe,
                    "airframe_effects": _airframe_effects(r["spec"], pop),
                    "spec": _spec_json(r["spec"]),
                    "truth": r["truth"],
                    "measured_snr_db": r["snr_mean"],
                    "measured_snr_std_db": r["snr_std"],
                }
                for r in results
            },
        }
        with atomic_file(key_path) as tmp:
            tmp.write_text(json.dumps(key, indent=1, default=float))
    if progress:
        print(
            f"emulated {len(results)} flights, {flown:.0f} s of flight in {wall:.1f} s "
            f"({flown / max(wall, 1e-9):.1f} s of flight per s, {workers} workers)",
            file=sys.stderr,
        )
    return rows


#: what :func:`emulate_world` writes into its folder
WORLD_FILES = ("flights.csv", "motor_logs.tsv")


def is_world_entry(path: Path) -> bool:
    """True for an entry of an emulated world's folder that :func:`emulate_world` wrote."""
    if path.name in WORLD_FILES and path.is_file():
        return True
    if path.name == "motor_logs" and path.is_dir() and not path.is_symlink():
        return all(f.is_file() and not f.is_symlink() and f.suffix == ".csv" for f in path.iterdir())
    return path.suffix == ".zarr" and is_tool_store(path)


def _emulate_into(out: Path, specs, progress: bool, workers: int):
    t0 = time.perf_counter()
    results = []
    if workers > 1:
        with ProcessPoolExecutor(workers) as ex:
            futs = [ex.submit(_emulate_one, s, str(out)) for s in specs]
            for k, f in enumerate(futs):
                results.append(f.result())
                if progress:
                    print(f"[{k + 1}/{len(specs)}] {specs[k].flight_id}", file=sys.stderr, flush=True)
    else:
        for k, s in enumerate(specs):
            results.append(_emulate_one(s, str(out)))
            if progress:
                print(f"[{k + 1}/{len(specs)}] {s.flight_id}", file=sys.stderr, flush=True)
    rows = []
    for r in results:
        s = r["spec"]
        rows.append(
            {
                "flight_id": s.flight_id,
                "target": s.target,
                "drone_model": s.drone_model,
                "bird_kind": s.bird_kind,
                "radar_id": s.radar_id,
                "duration_s": round(r["duration_s"], 4),
                "mean_range_m": round(r["mean_range_m"], 1),
                "mean_snr_db": round(r["snr_mean"], 2),
            }
        )
    _write_table(out / "flights.csv", rows, ",")
    _write_table(
        out / "motor_logs.tsv",
        [
            {
                "flight_id": r["spec"].flight_id,
                "motor_log": r["log"],
                "format": "csv",
                "unit": "rpm",
                "time_offset_s": 0,
            }
            for r in results
            if r["log"]
        ],
        "\t",
        header=["flight_id", "motor_log", "format", "unit", "time_offset_s"],
    )
    return rows, results, time.perf_counter() - t0


def _write_table(path: Path, rows: list[dict], sep: str, header=None) -> None:
    header = header or (list(rows[0]) if rows else [])
    with atomic_file(path) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=header, delimiter=sep)
        w.writeheader()
        for r in rows:
            w.writerow(r)
