"""Stage ``resample_motor_speeds``: each twin-able flight's logged motor speeds at
pulse rate, per sampling variant (``microdoppler.rotors.sampling``).

Twin-able flights are measured Inspire and Matrice flights; one without an ingested
motor log is reported and skipped (never guessed). The ``sub_cpi`` and
``single_motor`` rolling-average window is drawn per flight, uniformly in
[window_pulses_min, window_pulses_max], from a seed of (seed, variant, flight_id).
``fixed_speeds`` draws one speed around the model's typical speed
(``radar.DRONE_MODELS``). ``extended`` is ``sub_cpi`` (same seed) on the log as
transformed by the twin's model extensions (``ext.transform_log``; per flight, see
:mod:`.extended`).

Storage (schema ``speeds/2``): not the per-pulse speeds (float32 [n_pulses,
n_motors], 2.1 GB for ``sub_cpi`` at the paper profile's scale) but the knots they
are made from, ``knots_rev_s`` [n_knots, n_motors] (float32 for ``hold``, float64
for ``sub_cpi``), and the recipe in the group's attrs (``rev_s_form``, ``n_pulses`` and the form's parameters); the reader
(:func:`read_rev_s`) rebuilds the per-pulse speeds with the sampling's own code,
bit for bit the same float32 array ``speeds/1`` stored:

``hold`` (``per_cpi``, ``fixed_speeds``)
    Knot k held over pulses k * ``hold_pulses`` to (k + 1) * ``hold_pulses`` - 1:
    one knot per CPI (``hold_pulses`` = n_fft) or one for the flight.
``sub_cpi`` (``sub_cpi``, ``single_motor``, ``extended``)
    The decimated log, 8 knots per CPI (one per ``up`` = 512 pulses) plus ``pad``
    at each end, upsampled by the interpolating FIR and smoothed by the rolling
    average of ``window_pulses`` (:func:`microdoppler.rotors.sampling.sub_cpi_from_knots`).

``speeds/1`` stores are refused (:class:`~microdoppler.errors.InputError`):
re-run ``resample_motor_speeds``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..configfields import knob
from ..rotors import sampling as sampling
from ..errors import ConfigError, InputError
from ..io.inventory import list_flights, read_ingested_log
from ..synthesis.radar import DRONE_MODELS
from .extended import twin_extensions
from .split import twin_model
from .stores import open_store, put_array, stable_seed, writing_store

SPEEDS_SCHEMA = "speeds/2"
#: how the per-pulse speeds are rebuilt from the knots, per form: its parameters (group attrs)
FORMS = {"hold": ("hold_pulses",), "sub_cpi": ("up", "pad", "window_pulses")}
#: the sampling function behind each variant
BASE_SAMPLING = {
    "sub_cpi": "sub_cpi",
    "per_cpi": "per_cpi",
    "single_motor": "single_motor",
    "fixed_speeds": "fixed_speeds",
    "extended": "sub_cpi",
}


@dataclass(frozen=True)
class SubCpiSampling:
    """Settings of the ``sub_cpi`` and ``single_motor`` variants (config
    ``sampling.per_variant.<variant>``; ``extended`` takes ``sub_cpi``'s unless it
    has its own)."""

    per_cpi: int = knob(8, "Decimated motor-speed samples per CPI.", minimum=1)
    window_pulses_min: int = knob(
        2500, "Shortest rolling-average window drawn per flight [pulses] (paper 1500).", minimum=1
    )
    window_pulses_max: int = knob(
        2500, "Longest rolling-average window drawn per flight [pulses] (paper 3000).", minimum=1
    )


@dataclass(frozen=True)
class FixedSpeedsSampling:
    """Settings of the ``fixed_speeds`` variant (config ``sampling.per_variant.fixed_speeds``)."""

    spread: float = knob(0.1, "Relative half-width around the drone model's typical speed of the speed drawn.")


def draw_window(settings: dict, seed: int) -> int:
    """Rolling-average window [pulses] drawn uniformly in [window_pulses_min, window_pulses_max]."""
    lo, hi = int(settings.get("window_pulses_min", 2500)), int(settings.get("window_pulses_max", 2500))
    if not 1 <= lo <= hi:
        raise ConfigError("config", "sampling.per_variant.window_pulses_min/max", f"is {lo}/{hi}", "1 <= min <= max")
    return int(np.random.default_rng(seed).integers(lo, hi + 1))


@dataclass(frozen=True)
class CompactSpeeds:
    """One flight's per-pulse rotor speeds as knots and the recipe that rebuilds them.

    Parameters
    ----------
    form : str
        ``"hold"`` or ``"sub_cpi"`` (module docstring).
    knots_rev_s : ndarray, float32 (hold) or float64 (sub_cpi) [n_knots, n_motors]
        Knots [rev/s]; ``hold`` knots are the float32 values held, ``sub_cpi`` knots
        go through the FIR in float64.
    n_pulses : int
        Pulses of the flight.
    params : dict
        The form's parameters (:data:`FORMS`), ints.
    """

    form: str
    knots_rev_s: np.ndarray
    n_pulses: int
    params: dict

    def expand(self) -> np.ndarray:
        """The per-pulse speeds: float32 [n_pulses, n_motors] rev/s."""
        return expand_speeds(self.form, self.knots_rev_s, self.n_pulses, self.params)


def expand_speeds(form: str, knots_rev_s: np.ndarray, n_pulses: int, params: dict, source="speeds") -> np.ndarray:
    """Per-pulse speeds float32 [n_pulses, n_motors] rev/s from knots
    [n_knots, n_motors] by the recipe ``form`` with ``params`` (module docstring).

    ``source`` names the store group in errors."""
    if form not in FORMS:
        raise InputError(source, "attrs.rev_s_form", f"is {form!r}", " or ".join(map(repr, FORMS)))
    missing = [k for k in FORMS[form] if k not in params]
    if missing:
        raise InputError(source, f"attrs.{missing[0]}", "is missing", f"an int (rev_s_form {form!r})")
    knots = np.asarray(knots_rev_s, np.float64)
    if knots.ndim != 2 or knots.shape[1] < 1:
        raise InputError(source, "knots_rev_s", f"has shape {knots.shape}", "[n_knots, n_motors]")
    p = {k: int(params[k]) for k in FORMS[form]}
    step = p["hold_pulses"] if form == "hold" else p["up"]
    if step < 1 or p.get("pad", 0) < 0 or p.get("window_pulses", 1) < 1:
        raise InputError(source, "attrs", f"has {form} parameters {p}", "hold_pulses, up, window_pulses >= 1, pad >= 0")
    need = -(-n_pulses // step) + (2 * p["pad"] if form == "sub_cpi" else 0)
    if knots.shape[0] != need:
        raise InputError(
            source, "knots_rev_s", f"has {knots.shape[0]} knots for {n_pulses} pulses ({form}, {p})", f"{need} knots"
        )
    out = np.empty((n_pulses, knots.shape[1]), np.float32)
    for m in range(knots.shape[1]):
        if form == "hold":
            out[:, m] = np.repeat(knots[:, m], p["hold_pulses"])[:n_pulses]
        else:
            out[:, m] = sampling.sub_cpi_from_knots(knots[:, m], n_pulses, **p)
    return out


def resample_flight_compact(
    variant: str,
    log,
    n_pulses: int,
    prf_hz: float,
    drone_model: str,
    *,
    settings: dict,
    n_fft: int,
    seed: int,
    typical_hz: float | None = None,
) -> tuple[CompactSpeeds, dict]:
    """Rotor rates of one flight for ``variant``, as knots (:class:`CompactSpeeds`).

    ``typical_hz`` [rev/s]: the drone model's typical rotor speed that ``fixed_speeds``
    draws around; None: the catalog's (:data:`~microdoppler.synthesis.radar.DRONE_MODELS`).

    Returns
    -------
    speeds : CompactSpeeds
        ``speeds.expand()`` is float32 [n_pulses, n_motors] (one motor for
        single_motor), equal to ``sampling.resample`` of the variant.
    attrs : dict
        What was drawn: window_pulses or fixed_rev_s, and the seed.
    """
    base = BASE_SAMPLING.get(variant)
    if base is None:
        raise ConfigError("config", "sampling.variants", f"has {variant!r}", " or ".join(BASE_SAMPLING))
    attrs = {"variant": variant, "sampling": base, "seed": seed}
    if base == "fixed_speeds":
        cfg = sampling.SamplingConfig(n_fft=n_fft, fixed_spread=float(settings.get("spread", 0.1)))
        typical = DRONE_MODELS[drone_model].typical_motor_hz if typical_hz is None else float(typical_hz)
        _, f = sampling.fixed_speeds(log.n_motors, 1, typical, seed, cfg)
        attrs["fixed_rev_s"] = f
        knots = np.full((1, log.n_motors), f, np.float32)
        return CompactSpeeds("hold", knots, n_pulses, {"hold_pulses": max(n_pulses, 1)}), attrs
    if base == "per_cpi":
        cfg = sampling.SamplingConfig(n_fft=n_fft)
        knots = sampling.per_cpi_knots(log, n_pulses, prf_hz, cfg).astype(np.float32)  # what per_cpi holds
        return CompactSpeeds("hold", knots, n_pulses, {"hold_pulses": n_fft}), attrs
    attrs["window_pulses"] = draw_window(settings, seed)
    cfg = sampling.SamplingConfig(
        n_fft=n_fft, sub_cpi_per_cpi=int(settings.get("per_cpi", 8)), window_pulses=attrs["window_pulses"]
    )
    motors = [0] if base == "single_motor" else range(log.n_motors)
    knots = np.column_stack([sampling.sub_cpi_knots(log, m, n_pulses, prf_hz, cfg) for m in motors])
    params = {"up": n_fft // cfg.sub_cpi_per_cpi, "pad": cfg.sub_cpi_pad, "window_pulses": cfg.window_pulses}
    return CompactSpeeds("sub_cpi", knots, n_pulses, params), attrs


def resample_flight(
    variant: str, log, n_pulses: int, prf_hz: float, drone_model: str, *, settings: dict, n_fft: int, seed: int
) -> tuple[np.ndarray, dict]:
    """Rotor rates of one flight for ``variant``.

    Returns
    -------
    rev_s : ndarray, float32 [n_pulses, n_motors] (one motor for single_motor)
    attrs : dict
        What was drawn: window_pulses or fixed_rev_s, and the seed.
    """
    compact, attrs = resample_flight_compact(
        variant, log, n_pulses, prf_hz, drone_model, settings=settings, n_fft=n_fft, seed=seed
    )
    return compact.expand(), attrs


def write_flight_speeds(root, flight_id: str, speeds: CompactSpeeds, attrs: dict):
    """Write one flight's group of a ``speeds/2`` store: ``knots_rev_s`` and the
    recipe (``rev_s_form``, ``n_pulses``, the form's parameters) besides ``attrs``."""
    g = root.require_group(flight_id)
    g.attrs.update({**attrs, "rev_s_form": speeds.form, "n_pulses": int(speeds.n_pulses), **speeds.params})
    put_array(g, "knots_rev_s", speeds.knots_rev_s)
    return g


def open_speeds(path):
    """Open a ``results/speeds/{variant}.zarr`` store for reading (schema ``speeds/2``;
    an older one raises :class:`~microdoppler.errors.InputError`)."""
    try:
        return open_store(path, SPEEDS_SCHEMA)
    except InputError as exc:
        if exc.field != "attrs.schema":
            raise
        raise InputError(
            path, "attrs.schema", f"{exc.problem} (an older store: re-run resample_motor_speeds)", repr(SPEEDS_SCHEMA)
        ) from None


def read_rev_s(group, source="speeds") -> np.ndarray:
    """A flight's per-pulse rotor speeds from its group of a ``speeds/2`` store.

    Parameters
    ----------
    group : zarr.Group
        The flight's group (``open_speeds(path)[flight_id]``).
    source : str or Path
        Names the group in errors (e.g. ``f"{path}/{flight_id}"``).

    Returns
    -------
    rev_s : ndarray, float32 [n_pulses, n_motors]
        Rotation rates [rev/s], equal to those the sampling variant computes.
    """
    a = dict(group.attrs)
    if "knots_rev_s" not in group:
        old = " (a speeds/1 per-pulse array: re-run resample_motor_speeds)" if "rev_s" in group else ""
        raise InputError(source, "knots_rev_s", f"is missing{old}", "[n_knots, n_motors] rev/s")
    if "n_pulses" not in a:
        raise InputError(source, "attrs.n_pulses", "is missing", "the flight's pulse count")
    return expand_speeds(a.get("rev_s_form"), group["knots_rev_s"][...], int(a["n_pulses"]), a, source)


def own_typical_hz(flights: pd.DataFrame, logs_zarr) -> dict[str, float]:
    """Typical rotor speed [rev/s] of each drone model of ``flights`` that the catalog
    does not hold (a drone of your own): the median over its flights of each ingested
    log's median speed. The catalog's models keep their own (Table IV)."""
    if not Path(logs_zarr).exists():
        return {}
    speeds: dict[str, list[float]] = {}
    for fl in flights.itertuples():
        if fl.drone_model in DRONE_MODELS:
            continue
        ml = read_ingested_log(logs_zarr, fl.flight_id)
        if ml is not None:
            speeds.setdefault(fl.drone_model, []).append(float(np.median(ml.rev_s)))
    return {m: float(np.median(v)) for m, v in speeds.items()}


def build_speeds(
    measured_dir, logs_zarr, out, *, variant: str, settings: dict, n_fft: int, seed: int, extensions=None, log=print
) -> pd.DataFrame:
    """Write ``results/speeds/{variant}.zarr``: group per twin-able flight with
    ``knots_rev_s`` and its recipe (module docstring; read with :func:`read_rev_s`).

    Returns the status table (flight_id, drone_model, status, detail).
    """
    flights = list_flights(measured_dir)
    flights = flights[(flights.target == "drone") & flights.drone_model.map(twin_model)]
    typical = own_typical_hz(flights, logs_zarr)
    status, skipped = [], {}
    with writing_store(
        out,
        {
            "schema": SPEEDS_SCHEMA,
            "variant": variant,
            "unit": "rev/s",
            "settings": dict(settings),
            "n_fft": n_fft,
            "seed": seed,
        },
    ) as root:
        for fl in flights.itertuples():
            ml = read_ingested_log(logs_zarr, fl.flight_id) if Path(logs_zarr).exists() else None
            if ml is None:
                log(f"{fl.flight_id}: no motor log: skipped (no twin)")
                skipped[fl.flight_id] = "no motor log"
                status.append(
                    dict(flight_id=fl.flight_id, drone_model=fl.drone_model, status="skipped", detail="no motor log")
                )
                continue
            if extensions is not None:
                ml = twin_extensions(extensions, fl.flight_id, fl.drone_model, seed=seed).transform_log(ml)
            # extended draws sub_cpi's window: a twin without extensions is its sub_cpi twin
            fseed = stable_seed(seed, BASE_SAMPLING.get(variant, variant), fl.flight_id)
            sp, attrs = resample_flight_compact(
                variant,
                ml,
                int(fl.n_pulses),
                fl.prf_hz,
                fl.drone_model,
                settings=settings,
                n_fft=n_fft,
                seed=fseed,
                typical_hz=typical.get(fl.drone_model),
            )
            write_flight_speeds(root, fl.flight_id, sp, {**attrs, "drone_model": fl.drone_model, "prf_hz": fl.prf_hz})
            log(
                f"{fl.flight_id}: {variant} rev_s [{sp.n_pulses}, {sp.knots_rev_s.shape[1]}] as {sp.form} knots "
                f"{sp.knots_rev_s.shape}, mean {sp.knots_rev_s.mean():.1f} rev/s, {attrs}"
            )
            status.append(dict(flight_id=fl.flight_id, drone_model=fl.drone_model, status="ok", detail=""))
        root.attrs["skipped"] = skipped
    return pd.DataFrame(status, columns=["flight_id", "drone_model", "status", "detail"])
