"""Flight batches of the per-flight dataset stages (``datasets.flight_batches``).

With ``n_batches`` > 1 the workflow runs ``synthesize_flights`` and
``inject_background`` once per (variant, batch), each on the flights of its batch,
so a cluster runs them side by side. A flight's batch is a stable hash of its id
(:func:`flight_batch`), known before any job runs. Each twin's seed depends on the
flight id and never on the batch, so a flight's twin is the same for every
``n_batches``; :func:`merge_stores` and :func:`merge_tables` then assemble the
per-variant products (``results/injected/{variant}.zarr``,
``results/reports/table_iv_{variant}.csv``) that a single job writes with
``n_batches`` = 1.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pandas as pd

from ..errors import InputError
from ..io.outputs import MARK_ATTR
from .speeds import SPEEDS_SCHEMA
from .stores import flight_ids, open_store, stable_seed, writing_store
from .tables import write_csv


def flight_batch(flight_id: str, n_batches: int) -> int:
    """Batch (0 .. ``n_batches`` - 1) of ``flight_id``: CRC32 of the id modulo ``n_batches``."""
    if int(n_batches) < 1:
        raise InputError("config", "datasets.flight_batches", f"is {n_batches}", "an integer >= 1")
    return stable_seed("flight_batch", flight_id) % int(n_batches)


def batch_filter(batch: int | None, n_batches: int):
    """Predicate on flight ids: the flights of ``batch`` (every flight if ``batch`` is None)."""
    if batch is None:
        return lambda fid: True
    if not 0 <= int(batch) < int(n_batches):
        raise InputError("workflow", "batch", f"is {batch}", f"0 .. {int(n_batches) - 1}")
    return lambda fid: flight_batch(fid, n_batches) == int(batch)


def _link_or_copy(src, dst):
    """Hard link ``src`` at ``dst`` (chunks are never rewritten in place); copy if the
    file system refuses links."""
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)
    return dst


def merge_stores(paths, out, schema: str, *, log=print) -> list[str]:
    """Write the union of the flight groups of the batch stores ``paths`` to ``out``.

    Every batch store must carry the same root attributes (schema, variant, ...);
    ``out`` gets them, and each flight group is linked (or copied) unchanged, so
    ``out`` holds the same groups, attributes and arrays as one store written over
    all flights. A flight in two batch stores raises :class:`InputError`.

    Returns the merged flight ids, sorted.
    """
    roots = [open_store(p, schema) for p in paths]
    if not roots:
        raise InputError(out, "inputs", "is empty", "at least one batch store")
    attrs = {k: v for k, v in dict(roots[0].attrs).items() if k != MARK_ATTR}
    owner = {}
    for p, root in zip(paths, roots):
        other = {k: v for k, v in dict(root.attrs).items() if k != MARK_ATTR}
        if other != attrs:
            raise InputError(p, "attrs", f"are {other}", f"those of {paths[0]}: {attrs}")
        for fid in flight_ids(root):
            if fid in owner:
                raise InputError(p, fid, f"is also in {owner[fid]}", "each flight in one batch store")
            owner[fid] = p
    with writing_store(out, attrs) as root:
        tmp = Path(root.store.root)
        for fid in sorted(owner):
            shutil.copytree(Path(owner[fid]) / fid, tmp / fid, copy_function=_link_or_copy)
    log(f"{len(owner)} flights from {len(roots)} batch stores -> {out}")
    return sorted(owner)


def merge_tables(paths, speeds_zarr, out, *, log=print) -> pd.DataFrame:
    """Concatenate the batch tables ``paths`` (per-flight Table IV rows) into ``out``.

    Rows come in the order one job over all flights writes them: the flights the
    resampling skipped (``speeds_zarr`` root attribute ``skipped``), then the
    resampled flights sorted by id. Each flight must appear exactly once.
    """
    tables = [pd.read_csv(p, dtype={"flight_id": str}, keep_default_na=False, na_values=[""]) for p in paths]
    # an empty batch (more batches than flights) adds no rows and must not change dtypes
    df = pd.concat([t for t in tables if len(t)] or tables[:1], ignore_index=True)
    speeds = open_store(speeds_zarr, SPEEDS_SCHEMA)
    order = list(dict(speeds.attrs.get("skipped", {}))) + flight_ids(speeds)
    rank = {fid: i for i, fid in enumerate(order)}
    dup = df.flight_id[df.flight_id.duplicated()]
    if len(dup):
        raise InputError(out, "flight_id", f"{dup.iloc[0]!r} is in two batch tables", "each flight in one batch")
    missing = sorted(set(order) - set(df.flight_id))
    extra = sorted(set(df.flight_id) - set(order))
    if missing or extra:
        raise InputError(
            out, "flight_id", f"misses {missing[:3]} / has unknown {extra[:3]}", f"exactly the flights of {speeds_zarr}"
        )
    df = df.iloc[sorted(range(len(df)), key=lambda i: rank[df.flight_id.iloc[i]])].reset_index(drop=True)
    write_csv(df, out)
    log(f"{len(df)} Table IV rows from {len(tables)} batch tables -> {out}")
    return df
