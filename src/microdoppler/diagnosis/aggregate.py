"""Aggregate the diagnosis of the training flights into the ``extended`` variant."""

from __future__ import annotations

from collections import Counter

import numpy as np

from ..catalog import CAUSES
from ..extensions import ExtensionSet


def aggregate(report: dict, *, min_fraction: float = 0.25, flight_ids=None) -> ExtensionSet:
    """Extensions found in at least ``min_fraction`` of the diagnosed flights, each
    with the median of its fitted parameters over the flights that named it.

    Parameters
    ----------
    report : dict
        A diagnosis report (``{"catalog": [...], "flights": [...]}``).
    min_fraction : float
        Fraction of diagnosed flights that must name a cause for it to be kept.
    flight_ids : iterable of str, optional
        Only these flights (e.g. the training set).
    """
    if not 0 <= min_fraction <= 1:
        raise ValueError(f"min_fraction={min_fraction} must be in [0, 1]")
    flights = report.get("flights", [])
    if flight_ids is not None:
        keep = set(flight_ids)
        flights = [f for f in flights if f["flight_id"] in keep]
    n = len(flights)
    counts = Counter(f["cause"] for f in flights)
    effects = {}
    for cause, k in counts.items():
        if cause == "none" or n == 0 or k / n < min_fraction:
            continue
        names = [p.name for p in CAUSES[cause].params]
        vals = {p: [f["extension"]["params"][p] for f in flights
                    if f["cause"] == cause and f["extension"] and p in f["extension"]["params"]] for p in names}
        effects[cause] = {p: float(np.median(v)) for p, v in vals.items() if v}
    meta = {"base_variant": "sub_cpi", "n_flights": n, "cause_counts": dict(counts),
            "min_fraction": min_fraction, "parameters": "median over the flights that named the cause"}
    return ExtensionSet(effects, meta)
