"""Aggregate the diagnosis of the training flights into the ``extended`` variant."""

from __future__ import annotations

from collections import Counter

import numpy as np

from ..catalog import CAUSES
from ..extensions import ExtensionSet


def flight_causes(entry: dict) -> list[dict]:
    """The ``causes`` of a report entry: report 2's list, or report 1's single
    ``cause``/``extension`` as a list of 0 or 1 entries."""
    if "causes" in entry:
        return list(entry["causes"] or [])
    cause = entry.get("cause")
    if cause in (None, "none", "skipped"):
        return []
    return [{"cause": cause, "extension": entry.get("extension"), "gain": entry.get("gain")}]


def aggregate(report: dict, *, min_fraction: float = 0.25, flight_ids=None) -> ExtensionSet:
    """Extensions found in at least ``min_fraction`` of the diagnosed flights, each
    with the median of its fitted parameters over the flights that named it.

    Parameters
    ----------
    report : dict
        A diagnosis report (``diagnosis-report/2``: each flight's ``causes``; report
        1's single ``cause``/``extension`` per flight is read too).
    min_fraction : float
        Fraction of diagnosed flights that must name a cause for it to be kept;
        skipped flights (not diagnosed) do not count.
    flight_ids : iterable of str, optional
        Only these flights (e.g. the training set).
    """
    if not 0 <= min_fraction <= 1:
        raise ValueError(f"min_fraction={min_fraction} must be in [0, 1]")
    flights = report.get("flights", [])
    if flight_ids is not None:
        keep = set(flight_ids)
        flights = [f for f in flights if f["flight_id"] in keep]
    skipped = [f for f in flights if f.get("cause") == "skipped"]
    diagnosed = [f for f in flights if f.get("cause") != "skipped"]
    n = len(diagnosed)
    named = {f["flight_id"]: flight_causes(f) for f in diagnosed}
    counts = Counter(c for cs in named.values() for c in {x["cause"] for x in cs})
    effects = {}
    for cause, k in counts.items():
        if cause == "none" or n == 0 or k / n < min_fraction:
            continue
        names = [p.name for p in CAUSES[cause].params]
        vals = {p: [c["extension"]["params"][p] for cs in named.values() for c in cs
                    if c["cause"] == cause and c.get("extension") and p in c["extension"].get("params", {})]
                for p in names}
        effects[cause] = {p: float(np.median(v)) for p, v in vals.items() if v}
    n_none = sum(1 for cs in named.values() if not cs)
    meta = {"base_variant": "sub_cpi", "n_flights": n, "n_skipped": len(skipped),
            "cause_counts": {**dict(counts), **({"none": n_none} if n_none else {})},
            "min_fraction": min_fraction, "parameters": "median over the flights that named the cause"}
    return ExtensionSet(effects, meta)
