"""Stage ``resample_motor_speeds``: each twin-able flight's logged motor speeds at
pulse rate, per sampling variant (``microdoppler.sampling``).

Twin-able flights are measured Inspire and Matrice flights; one without an ingested
motor log is reported and skipped (never guessed). The ``sub_cpi`` and
``single_motor`` rolling-average window is drawn per flight, uniformly in
[window_pulses_min, window_pulses_max], from a seed of (seed, variant, flight_id).
``fixed_speeds`` draws one speed around the model's typical speed
(``radar.DRONE_MODELS``). ``extended`` is ``sub_cpi`` (same seed) on the log as
transformed by the twin's model extensions (``ext.transform_log``; per flight, see
:mod:`.extended`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from .. import sampling
from ..errors import ConfigError
from ..inventory import list_flights, read_ingested_log
from ..radar import DRONE_MODELS
from .extended import twin_extensions
from .split import TWIN_MODELS
from .stores import put_array, stable_seed, writing_store

SPEEDS_SCHEMA = "speeds/1"
#: the sampling function behind each variant
BASE_SAMPLING = {"sub_cpi": "sub_cpi", "per_cpi": "per_cpi", "single_motor": "single_motor",
                 "fixed_speeds": "fixed_speeds", "extended": "sub_cpi"}


def draw_window(settings: dict, seed: int) -> int:
    """Rolling-average window [pulses] drawn uniformly in [window_pulses_min, window_pulses_max]."""
    lo, hi = int(settings.get("window_pulses_min", 2500)), int(settings.get("window_pulses_max", 2500))
    if not 1 <= lo <= hi:
        raise ConfigError("config", "sampling.per_variant.window_pulses_min/max", f"is {lo}/{hi}", "1 <= min <= max")
    return int(np.random.default_rng(seed).integers(lo, hi + 1))


def resample_flight(variant: str, log, n_pulses: int, prf_hz: float, drone_model: str, *, settings: dict,
                    n_fft: int, seed: int) -> tuple[np.ndarray, dict]:
    """Rotor rates of one flight for ``variant``.

    Returns
    -------
    rev_s : ndarray, float32 [n_pulses, n_motors] (one motor for single_motor)
    attrs : dict
        What was drawn: window_pulses or fixed_rev_s, and the seed.
    """
    base = BASE_SAMPLING.get(variant)
    if base is None:
        raise ConfigError("config", "sampling.variants", f"has {variant!r}", " or ".join(BASE_SAMPLING))
    attrs = {"variant": variant, "sampling": base, "seed": seed}
    if base == "fixed_speeds":
        cfg = sampling.SamplingConfig(n_fft=n_fft, fixed_spread=float(settings.get("spread", 0.1)))
        rev, f = sampling.fixed_speeds(log.n_motors, n_pulses, DRONE_MODELS[drone_model].typical_motor_hz, seed, cfg)
        attrs["fixed_rev_s"] = f
        return rev, attrs
    kw = {"n_fft": n_fft}
    if base in ("sub_cpi", "single_motor"):
        kw["sub_cpi_per_cpi"] = int(settings.get("per_cpi", 8))
        kw["window_pulses"] = attrs["window_pulses"] = draw_window(settings, seed)
    cfg = sampling.SamplingConfig(**kw)
    return sampling.resample(base, log, n_pulses, prf_hz, seed=seed, cfg=cfg).astype(np.float32), attrs


def build_speeds(measured_dir, logs_zarr, out, *, variant: str, settings: dict, n_fft: int, seed: int,
                 extensions=None, log=print) -> pd.DataFrame:
    """Write ``results/speeds/{variant}.zarr``: group per twin-able flight with ``rev_s``.

    Returns the status table (flight_id, drone_model, status, detail).
    """
    flights = list_flights(measured_dir)
    flights = flights[(flights.target == "drone") & flights.drone_model.isin(TWIN_MODELS)]
    status, skipped = [], {}
    with writing_store(out, {"schema": SPEEDS_SCHEMA, "variant": variant, "unit": "rev/s",
                             "settings": dict(settings), "n_fft": n_fft, "seed": seed}) as root:
        for fl in flights.itertuples():
            ml = read_ingested_log(logs_zarr, fl.flight_id) if Path(logs_zarr).exists() else None
            if ml is None:
                log(f"{fl.flight_id}: no motor log: skipped (no twin)")
                skipped[fl.flight_id] = "no motor log"
                status.append(dict(flight_id=fl.flight_id, drone_model=fl.drone_model, status="skipped", detail="no motor log"))
                continue
            if extensions is not None:
                ml = twin_extensions(extensions, fl.flight_id, fl.drone_model, seed=seed).transform_log(ml)
            # extended draws sub_cpi's window: a twin without extensions is its sub_cpi twin
            fseed = stable_seed(seed, BASE_SAMPLING.get(variant, variant), fl.flight_id)
            rev, attrs = resample_flight(variant, ml, int(fl.n_pulses), fl.prf_hz, fl.drone_model,
                                         settings=settings, n_fft=n_fft, seed=fseed)
            g = root.require_group(fl.flight_id)
            g.attrs.update({**attrs, "drone_model": fl.drone_model, "prf_hz": fl.prf_hz})
            put_array(g, "rev_s", rev)
            log(f"{fl.flight_id}: {variant} rev_s {rev.shape}, mean {rev.mean():.1f} rev/s, {attrs}")
            status.append(dict(flight_id=fl.flight_id, drone_model=fl.drone_model, status="ok", detail=""))
        root.attrs["skipped"] = skipped
    return pd.DataFrame(status, columns=["flight_id", "drone_model", "status", "detail"])
