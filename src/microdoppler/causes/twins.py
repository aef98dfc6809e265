"""The ``extended`` variant's model extensions, per twin (``extensions/2``).

The diagnosis names, for each diagnosed measured flight, its causes and their fitted
parameters. :class:`TwinExtensions` holds

* ``flights``: per diagnosed (or skipped) flight, its drone model, its status and its
  own causes with their parameters;
* ``population``: per drone model, over its diagnosed flights, the incidence of each
  cause (fraction of the model's flights that named it) and the empirical
  distribution of its parameters (one parameter set per flight that named it, sign
  included);
* ``mode``: how :meth:`TwinExtensions.for_flight` picks a twin's extensions:

  ``per_flight`` (default)
      The twin of a flight in ``flights`` gets that flight's own causes and
      parameters; a flight diagnosed with no cause, or skipped, gets none (its twin
      equals the ``sub_cpi`` twin). A flight not in ``flights`` (a motor log without a
      diagnosed measured flight, e.g. outside the diagnosed split sets) draws from the
      population as below.
  ``population``
      Every twin draws: each cause of its drone model's population is switched on
      with probability equal to its incidence and then takes the parameter set of one
      of the model's flights that named it, chosen uniformly; seeded by
      (seed, flight_id), so the same seed gives the same draw in every stage.

The per-twin object is :class:`microdoppler.causes.extensions.ExtensionSet`; its ``meta``
says where it came from (``source``). ``extensions/1`` files (one ExtensionSet for
every twin) are read too.

YAML layout (``extensions/2``)::

    schema: extensions/2
    mode: per_flight
    flights:
      d025_inspire2: {drone_model: inspire2, status: diagnosed,
                      extensions: {sideband_asymmetry: {asymmetry_db: 4.1}}}
      d030_inspire2: {drone_model: inspire2, status: skipped, extensions: {}}
    population:
      inspire2:
        n_flights: 7          # diagnosed flights of the model
        causes:
          sideband_asymmetry: {incidence: 0.71, samples: [{asymmetry_db: 4.1}, ...]}
    meta: {...}
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np
import yaml

from ..errors import InputError
from ..io.outputs import atomic_file
from ..synthesis.processes import stable_seed
from . import registry
from .catalog import CAUSES
from .extensions import ExtensionSet, check_params, yaml_plain

SCHEMA = "extensions/2"
#: how a twin's extensions are chosen (see the module docstring)
MODES = ("per_flight", "population")
#: status of a flight in the per-flight map
STATUSES = ("diagnosed", "skipped")


def _order() -> list:
    """The registered causes in the catalog's order (the order of the population
    draws; read at call time)."""
    return [c for c in CAUSES if c != "none"]


def catalog_params(cause: str, params: Mapping | None) -> dict:
    """The catalog parameters of ``params`` (an extension may carry more; those the
    per-twin :class:`ExtensionSet` does not take are left out)."""
    names = [p.name for p in CAUSES[cause].params] if cause in CAUSES else []
    return {k: v for k, v in dict(params or {}).items() if k in names}


@dataclass(frozen=True)
class TwinExtensions:
    """Per-flight extensions and their per-model population (see the module docstring).

    Parameters
    ----------
    flights : mapping
        ``{flight_id: {"drone_model": str, "status": "diagnosed"|"skipped",
        "extensions": {cause: {param: value}}}}``.
    population : mapping
        ``{drone_model: {"n_flights": int, "causes": {cause: {"incidence": float in
        [0, 1], "samples": [{param: value}, ...]}}}}``.
    mode : {"per_flight", "population"}
    meta : mapping
        Free-form provenance.
    """

    flights: Mapping = field(default_factory=dict)
    population: Mapping = field(default_factory=dict)
    mode: str = "per_flight"
    meta: Mapping = field(default_factory=dict)

    def __post_init__(self):
        d = _check(
            {
                "schema": SCHEMA,
                "mode": self.mode,
                "flights": self.flights,
                "population": self.population,
                "meta": self.meta,
            },
            "TwinExtensions",
        )
        object.__setattr__(self, "flights", d["flights"])
        object.__setattr__(self, "population", d["population"])

    def with_mode(self, mode: str) -> "TwinExtensions":
        """The same extensions with another ``mode``."""
        return TwinExtensions(self.flights, self.population, mode, self.meta)

    def draw(self, flight_id: str, drone_model: str, *, seed: int) -> dict:
        """Population draw for one twin: ``{cause: params}`` (deterministic in
        (``seed``, ``flight_id``); empty when the model has no population)."""
        pop = self.population.get(drone_model, {}).get("causes", {})
        rng = np.random.default_rng(stable_seed(seed, "extended-population", flight_id))
        out = {}
        for cause in _order():
            u, r = rng.uniform(), rng.uniform()  # two draws per cause whatever happens
            c = pop.get(cause)
            if c is None or not c["samples"] or u >= c["incidence"]:
                continue
            out[cause] = dict(c["samples"][min(int(r * len(c["samples"])), len(c["samples"]) - 1)])
        return out

    def for_flight(self, flight_id: str, drone_model: str, *, seed: int) -> ExtensionSet:
        """The extensions of the twin of ``flight_id``; ``meta['source']`` is
        ``own`` (its flight's diagnosed causes, possibly none), ``skipped`` (its
        flight was not diagnosable: none) or ``population`` (drawn)."""
        entry = self.flights.get(flight_id)
        if self.mode == "per_flight" and entry is not None:
            source = "own" if entry["status"] == "diagnosed" else "skipped"
            effects = entry["extensions"] if source == "own" else {}
        else:
            source, effects = "population", self.draw(flight_id, drone_model, seed=seed)
        return ExtensionSet(
            effects, {"source": source, "mode": self.mode, "flight_id": flight_id, "drone_model": drone_model}
        )

    def to_dict(self) -> dict:
        return yaml_plain(
            {
                "schema": SCHEMA,
                "mode": self.mode,
                "flights": self.flights,
                "population": self.population,
                "meta": dict(self.meta),
            }
        )


def twin_extensions(extensions, flight_id: str, drone_model: str, *, seed: int):
    """The per-twin extensions: ``extensions.for_flight(...)`` for a
    :class:`TwinExtensions`, ``extensions`` itself otherwise (one set for every twin,
    e.g. an ``extensions/1`` :class:`ExtensionSet`), None for None."""
    if extensions is None or not hasattr(extensions, "for_flight"):
        return extensions
    return extensions.for_flight(flight_id, drone_model, seed=seed)


def fit_population(flights: Mapping) -> dict:
    """Per-model population from a per-flight map (``TwinExtensions.flights``):
    over each model's diagnosed flights, each cause's incidence and its parameter sets."""
    pop: dict = {}
    for fid in sorted(flights):
        e = flights[fid]
        if e["status"] != "diagnosed":
            continue
        m = pop.setdefault(e["drone_model"], {"n_flights": 0, "causes": {}, "flights": []})
        m["n_flights"] += 1
        m["flights"].append(fid)
        for cause, params in e["extensions"].items():
            m["causes"].setdefault(cause, {"samples": []})["samples"].append(dict(params))
    for m in pop.values():
        for cause, c in m["causes"].items():
            c["incidence"] = len(c["samples"]) / m["n_flights"]
            c["median"] = {k: float(np.median([s[k] for s in c["samples"]])) for k in c["samples"][0]}
        m["causes"] = {c: m["causes"][c] for c in _order() if c in m["causes"]}
    return pop


def load_twin_extensions(path_yaml, *, mode: str | None = None):
    """Read an extensions YAML: ``extensions/2`` -> :class:`TwinExtensions` (``mode``
    overrides the file's), ``extensions/1`` -> one :class:`ExtensionSet` for every twin.

    Raises
    ------
    InputError
        Missing file, not YAML, unknown schema, or a field that breaks the layout
        (one line naming the file, the field and what was expected).
    """
    from .extensions import SCHEMA as SCHEMA_1
    from .extensions import extensions_from_dict, read_yaml

    path = Path(path_yaml)
    d = read_yaml(path, f"an {SCHEMA} or {SCHEMA_1} YAML file")
    schema = d.get("schema") if isinstance(d, dict) else None
    if schema == SCHEMA_1:
        return extensions_from_dict(d, path)
    if schema != SCHEMA:
        raise InputError(path, "schema", f"is {schema if isinstance(d, dict) else d!r}", f"{SCHEMA!r} or {SCHEMA_1!r}")
    if mode is not None:
        d["mode"] = mode
    d = _check(d, path)
    return TwinExtensions(d["flights"], d["population"], d["mode"], d["meta"])


def save_twin_extensions(ext: TwinExtensions, path_yaml) -> Path:
    """Write ``ext`` as ``extensions/2`` YAML, atomically."""
    path = Path(path_yaml)
    with atomic_file(path) as tmp:
        tmp.write_text(yaml.safe_dump(ext.to_dict(), sort_keys=False))
    return path


def _check(d: dict, source) -> dict:
    """Validate an ``extensions/2`` mapping; returns it with checked float parameters."""
    mode = d.get("mode", "per_flight")
    if mode not in MODES:
        raise InputError(source, "mode", f"is {mode!r}", " or ".join(MODES))
    flights, pop, meta = d.get("flights") or {}, d.get("population") or {}, d.get("meta") or {}
    for name, x in (("flights", flights), ("population", pop), ("meta", meta)):
        if not isinstance(x, Mapping):
            raise InputError(source, name, f"is a {type(x).__name__}", "a mapping")
    out_f = {}
    for fid, e in flights.items():
        where = f"flights.{fid}"
        if not isinstance(e, Mapping):
            raise InputError(
                source, where, f"is a {type(e).__name__}", "a mapping with drone_model, status, extensions"
            )
        if e.get("status", "diagnosed") not in STATUSES:
            raise InputError(source, f"{where}.status", f"is {e.get('status')!r}", " or ".join(STATUSES))
        if not isinstance(e.get("drone_model", ""), str):
            raise InputError(source, f"{where}.drone_model", f"is {e.get('drone_model')!r}", "a drone model name")
        out_f[str(fid)] = {
            "drone_model": e.get("drone_model", ""),
            "status": e.get("status", "diagnosed"),
            "extensions": _effects(e.get("extensions"), f"{where}.extensions", source),
        }
    out_p = {}
    for model, m in pop.items():
        where = f"population.{model}"
        if not isinstance(m, Mapping) or not isinstance(m.get("causes", {}), Mapping):
            raise InputError(source, where, "is not a mapping with causes", "{n_flights, causes: {cause: ...}}")
        n = m.get("n_flights", 0)
        if isinstance(n, bool) or not isinstance(n, int) or n < 0:
            raise InputError(source, f"{where}.n_flights", f"is {n!r}", "an integer >= 0")
        causes = {}
        for cause, c in (m.get("causes") or {}).items():
            w = f"{where}.causes.{cause}"
            if not isinstance(c, Mapping):
                raise InputError(source, w, f"is a {type(c).__name__}", "{incidence, samples}")
            inc = c.get("incidence")
            if isinstance(inc, bool) or not isinstance(inc, (int, float)) or not 0 <= inc <= 1:
                raise InputError(source, f"{w}.incidence", f"is {inc!r}", "a number in [0, 1]")
            samples = c.get("samples")
            if not isinstance(samples, list) or not samples:
                raise InputError(source, f"{w}.samples", f"is {samples!r}", "a non-empty list of parameter mappings")
            checked = [_effects({cause: s}, f"{w}.samples[{i}]", source)[cause] for i, s in enumerate(samples)]
            causes[str(cause)] = {
                **{k: v for k, v in c.items() if k not in ("incidence", "samples")},
                "incidence": float(inc),
                "samples": checked,
            }
        out_p[str(model)] = {**{k: v for k, v in m.items() if k not in ("causes",)}, "n_flights": n, "causes": causes}
    return {"schema": SCHEMA, "mode": mode, "flights": out_f, "population": out_p, "meta": dict(meta)}


def _effects(x, where: str, source) -> dict:
    if x is None:
        return {}
    if not isinstance(x, Mapping):
        raise InputError(source, where, f"is a {type(x).__name__}", "a mapping cause -> params")
    out = {}
    for cause, params in x.items():
        if params is not None and not isinstance(params, Mapping):
            raise InputError(source, f"{where}.{cause}", f"is {params!r}", "a mapping param -> number")
        try:
            out[cause] = check_params(cause, params, source=source)
        except InputError as exc:
            raise InputError(
                source, f"{where}.{cause}" + exc.field.split(cause, 1)[-1], exc.problem, exc.expected
            ) from None
    return out


#: offset of the background's phase-noise stream from the twin's seed
_BACKGROUND_STREAM = 7919


def inject(
    target_iq: np.ndarray,
    background_iq: np.ndarray,
    source: str = "twin",
    *,
    effects: dict | None = None,
    prf_hz: float | None = None,
    seed: int = 0,
) -> np.ndarray:
    """Sum of the simulated target and the recorded background, complex64 [n_pulses].

    ``effects`` (a twin's extensions, ``{cause: params}``): with a phase noise (a
    cause that ``acts_on_background``) the radar's extra phase noise also acts on
    the background, as it acts on everything
    the radar receives during the flight (clutter included, whose skirt is what the
    diagnosis sees next to the clutter line). The twin's target already carries its
    own draw (``ExtensionSet.post``); target and clutter are independent, so two
    independent phase draws give the sum the same spectrum as one common one.
    ``prf_hz`` is then required; ``seed`` is the twin's seed.

    Parameters
    ----------
    target_iq : ndarray, complex64 [n_pulses]
        The simulated target (a twin).
    background_iq : ndarray, complex64 [n_pulses]
        The recorded target-free background (a flight's ``background_iq``).
    source : str
        Named in errors.
    effects : dict, optional
        ``{cause: params}`` of the twin's extensions.
    prf_hz : float, optional
        Pulse repetition frequency [Hz]; needed with a phase noise.
    seed : int
        The twin's seed.

    Returns
    -------
    ndarray, complex64 [n_pulses]
        Target plus background.

    Raises
    ------
    microdoppler.errors.InputError
        When the background is missing or its length differs from the target's.

    See Also
    --------
    microdoppler.datasets.fit_twin

    Examples
    --------
    >>> import numpy as np
    >>> from microdoppler.datasets import inject
    >>> x = inject(np.ones(4, np.complex64), np.full(4, 1j, np.complex64))
    >>> x.dtype, x.tolist()
    (dtype('complex64'), [(1+1j), (1+1j), (1+1j), (1+1j)])
    >>> inject(np.ones(4, np.complex64), None)
    Traceback (most recent call last):
    ...
    microdoppler.errors.InputError: twin: background/iq: missing (expected a target-free recording of ...)
    """
    if background_iq is None:
        raise InputError(source, "background/iq", "missing", "a target-free recording of the flight's cells")
    if len(target_iq) != len(background_iq):
        raise InputError(source, "background/iq", f"has {len(background_iq)} pulses", f"{len(target_iq)} (the twin's)")
    bg = np.asarray(background_iq, np.complex64)
    # the causes whose post-step acts on everything the radar receives (a phase noise)
    on_bg = {
        s.name: dict(effects[s.name]) for s in registry.specs() if s.acts_on_background and s.name in (effects or {})
    }
    if on_bg:
        if prf_hz is None:
            raise ValueError(f"inject: prf_hz is needed to apply {', '.join(on_bg)} to the background")
        bg = ExtensionSet(on_bg).post(bg, prf_hz=float(prf_hz), seed=(int(seed) + _BACKGROUND_STREAM) % 2**31)
    return (np.asarray(target_iq, np.complex64) + bg).astype(np.complex64)
