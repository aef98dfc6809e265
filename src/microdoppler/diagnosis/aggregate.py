"""Aggregate the diagnosis of the training flights into the ``extended`` variant.

:func:`aggregate_twins` (``extensions/2``): each twin gets its own flight's causes, or
a draw from their per-model population. :func:`aggregate` (``extensions/1``): one set
of median parameters for every twin (kept for comparison).
"""

from __future__ import annotations

from collections import Counter
from typing import Mapping

import numpy as np

from ..causes.catalog import CAUSES, UNEXPLAINED
from ..causes.extensions import ExtensionSet


def flight_causes(entry: dict) -> list[dict]:
    """The ``causes`` of a report entry that name a catalog cause (an extension):
    report 2's list without ``unexplained`` (which names none), or report 1's single
    ``cause``/``extension`` as a list of 0 or 1 entries."""
    if "causes" in entry:
        return [c for c in entry["causes"] or [] if c.get("cause") != UNEXPLAINED]
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

    Returns
    -------
    microdoppler.synthesis.ExtensionSet
        The kept causes with their median parameters; ``meta`` counts the flights,
        the skipped ones and each cause.

    Raises
    ------
    ValueError
        When ``min_fraction`` is outside [0, 1].

    See Also
    --------
    diagnose, microdoppler.causes.save_extensions

    Examples
    --------
    Two of three diagnosed flights name a motor-speed scale, one is skipped:

    >>> from microdoppler.diagnosis import aggregate
    >>> def named(scale):
    ...     return [{"cause": "motor_speed_scale", "extension": {"params": {"scale": scale}}}]
    >>> report = {"flights": [{"flight_id": "a", "cause": "motor_speed_scale", "causes": named(1.04)},
    ...                       {"flight_id": "b", "cause": "motor_speed_scale", "causes": named(1.06)},
    ...                       {"flight_id": "c", "cause": "none", "causes": []},
    ...                       {"flight_id": "d", "cause": "skipped", "reason": "a bird"}]}
    >>> ext = aggregate(report)
    >>> ext.effects
    {'motor_speed_scale': {'scale': 1.05}}
    >>> ext.meta["n_flights"], ext.meta["n_skipped"]
    (3, 1)
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
        vals = {
            p: [
                c["extension"]["params"][p]
                for cs in named.values()
                for c in cs
                if c["cause"] == cause and c.get("extension") and p in c["extension"].get("params", {})
            ]
            for p in names
        }
        effects[cause] = {p: float(np.median(v)) for p, v in vals.items() if v}
    n_none = sum(1 for cs in named.values() if not cs)
    meta = {
        "base_variant": "sub_cpi",
        "n_flights": n,
        "n_skipped": len(skipped),
        "cause_counts": {**dict(counts), **({"none": n_none} if n_none else {})},
        "min_fraction": min_fraction,
        "parameters": "median over the flights that named the cause",
    }
    return ExtensionSet(effects, meta)


def aggregate_twins(
    report: dict,
    drone_models: Mapping[str, str],
    *,
    flight_ids=None,
    population_ids=None,
    mode: str = "per_flight",
    source="report",
):
    """The ``extended`` variant's per-twin extensions (``extensions/2``) from a report.

    Parameters
    ----------
    report : dict
        A diagnosis report (``diagnosis-report/2``, or report 1).
    drone_models : mapping
        ``{flight_id: drone_model}`` (e.g. from the split table); a flight missing
        here is taken from the report entry's ``drone_model`` if any.
    flight_ids : iterable of str, optional
        Only these flights (e.g. the diagnosed split sets).
    population_ids : iterable of str, optional
        The per-model population is fitted on these flights only (e.g. the training
        set, so that no test flight shapes a population-drawn training twin); default
        every flight kept.
    mode : {"per_flight", "population"}
        How the twins pick their extensions (:mod:`microdoppler.causes.twins`).
    source : str
        Named in errors.

    Returns
    -------
    TwinExtensions
        Per-flight map (each flight's causes with their catalog parameters; skipped
        flights with status ``skipped``) and per-model population (incidence and
        parameter sets of each cause over the model's diagnosed flights).
    """
    from ..causes.twins import MODES, TwinExtensions, catalog_params, fit_population
    from ..errors import InputError

    if mode not in MODES:
        raise InputError(source, "mode", f"is {mode!r}", " or ".join(MODES))
    flights = report.get("flights", []) if isinstance(report, dict) else None
    if not isinstance(flights, list):
        raise InputError(source, "flights", "is missing or not a list", "a list of flight entries")
    keep = None if flight_ids is None else set(flight_ids)
    out = {}
    for i, f in enumerate(flights):
        if not isinstance(f, dict) or "flight_id" not in f:
            raise InputError(source, f"flights[{i}]", "has no flight_id", "a mapping with flight_id")
        fid = str(f["flight_id"])
        if keep is not None and fid not in keep:
            continue
        model = drone_models.get(fid) or f.get("drone_model") or ""
        if f.get("cause") == "skipped":
            out[fid] = {"drone_model": model, "status": "skipped", "extensions": {}, "reason": f.get("reason", "")}
            continue
        effects = {}
        for c in flight_causes(f):
            cause = c.get("cause")
            if cause in (None, "none") or cause in effects:
                continue
            if cause not in CAUSES:
                raise InputError(
                    source, f"flights[{i}].causes.{cause}", "is not a catalog cause", f"one of {list(CAUSES)}"
                )
            effects[cause] = catalog_params(cause, (c.get("extension") or {}).get("params"))
        out[fid] = {"drone_model": model, "status": "diagnosed", "extensions": effects}
    n_diag = sum(1 for e in out.values() if e["status"] == "diagnosed")
    meta = {
        "base_variant": "sub_cpi",
        "report_schema": report.get("schema", ""),
        "n_flights": len(out),
        "n_diagnosed": n_diag,
        "n_skipped": len(out) - n_diag,
        "cause_counts": dict(Counter(c for e in out.values() for c in e["extensions"])),
        "parameters": "per_flight: each flight's own fitted parameters; population: per drone model, "
        "incidence = fraction of its diagnosed flights naming the cause, parameters drawn "
        "from the flights that named it",
    }
    pop_keep = None if population_ids is None else set(population_ids)
    pop_flights = {f: e for f, e in out.items() if pop_keep is None or f in pop_keep}
    meta["n_population_flights"] = sum(1 for e in pop_flights.values() if e["status"] == "diagnosed")
    return TwinExtensions(out, fit_population(pop_flights), mode, meta)
