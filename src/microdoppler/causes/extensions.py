"""Model extensions: the catalog's causes as options of the synthesis stage.

Each registered cause (:mod:`microdoppler.causes.registry`; ``none`` aside) extends the
paper's model (eq. 2, :func:`microdoppler.synthesis.model.synthesize`) with the
catalog's parameter names, units and signs. What each extension does is its cause
module's (:class:`~microdoppler.causes.base.CauseSpec`: ``transform_log``,
``model_extension``, ``blade_amplitudes``, ``post``); :class:`ExtensionSet` applies
the named ones in the registry's order:

- :meth:`ExtensionSet.transform_log`: the motor log that drives the blades (a lag, a scale);
- :meth:`ExtensionSet.model_extensions`: the envelope gain and the blade and body hooks
  acting inside the synthesis (an asymmetry, a fading, a body fluctuation);
- :meth:`ExtensionSet.blade_amplitudes`: unequal blades (an imbalance);
- :meth:`ExtensionSet.post`: a post-step on the echo (phase noise).

Stochastic extensions draw their processes from the ``seed`` given to
:meth:`~ExtensionSet.model_extensions` / :meth:`~ExtensionSet.post` (each cause on its
own sub-stream); the same seed gives the same result.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np
import yaml

from ..errors import InputError
from ..io.motorlog import MotorLog
from ..io.outputs import atomic_file
from ..synthesis.model import ModelExtensions
from . import registry
from .base import number
from .body_fluctuation import BODY_TIMESCALE_S  # noqa: F401 (re-exported)
from .catalog import CAUSES
from .phase_noise import (
    check_skirt_profile,
    flat_phase_noise,  # noqa: F401 (re-exported)
    profile_phase_noise,
)
from .sideband_asymmetry import asymmetry_envelope  # noqa: F401 (re-exported)
from .sideband_fading import DEFAULT_FADING_TIMESCALE_S  # noqa: F401 (re-exported)

SCHEMA = "extensions/1"


def check_params(cause: str, params: Mapping | None, *, source="extensions") -> dict:
    """Validate one cause's parameters against the catalog; returns floats.

    Raises
    ------
    InputError
        Unknown cause or parameter, missing or out-of-range value.
    """
    if cause not in CAUSES or cause == "none":
        raise InputError(
            source, f"extensions.{cause}", "is not a catalog cause", f"one of {[c for c in CAUSES if c != 'none']}"
        )
    spec = registry.get(cause)
    params = dict(params or {})
    names = spec.param_names
    extra = spec.extra_params(params)
    for k in params:
        if k not in names:
            raise InputError(source, f"extensions.{cause}.{k}", "unknown parameter", f"one of {names}")
    spec.complete_params(params, source)
    out = {}
    for k in names:
        if k not in params:
            raise InputError(source, f"extensions.{cause}.{k}", "missing", "a number")
        out[k] = number(source, cause, k, params[k])
    for k, want in spec.bounds:
        if (out[k] <= 0) if want == "> 0" else (out[k] < 0):
            raise InputError(source, f"extensions.{cause}.{k}", f"is {out[k]}", want)
    if extra:
        out.update(spec.check_extra(extra, source))
    return out


@dataclass(frozen=True)
class ExtensionSet:
    """A set of model extensions with their parameters.

    Parameters
    ----------
    effects : mapping
        ``{cause: {param: value}}`` with the catalog's names (``none`` not allowed);
        empty = the paper's model.
    meta : mapping
        Free-form provenance (e.g. how the parameters were aggregated); preserved by
        :func:`~microdoppler.causes.save_extensions`.

    Raises
    ------
    microdoppler.errors.InputError
        For an unknown cause or parameter, or a value out of the catalog's range.

    See Also
    --------
    load_extensions, microdoppler.diagnosis.aggregate

    Examples
    --------
    >>> from microdoppler.causes import ExtensionSet
    >>> ext = ExtensionSet({"motor_speed_scale": {"scale": 1.02}})
    >>> "motor_speed_scale" in ext, "phase_noise" in ext
    (True, False)
    """

    effects: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    meta: Mapping = field(default_factory=dict)

    def __post_init__(self):
        checked = {c: check_params(c, p) for c, p in dict(self.effects).items()}
        object.__setattr__(self, "effects", checked)

    def __contains__(self, cause: str) -> bool:
        return cause in self.effects

    def _named(self):
        """(spec, params) of the named causes, in the registry's order."""
        return [(s, self.effects[s.name]) for s in registry.specs() if s.name in self.effects]

    def transform_log(self, log: MotorLog) -> MotorLog:
        """Motor log corrected by lag and scale: the speeds that drive the blades."""
        t, rpm = log.time_s, log.rpm
        for spec, p in self._named():
            t, rpm = spec.transform_log(p, t, rpm)
        return MotorLog(np.asarray(t, np.float64), rpm, log.source)

    def model_extensions(self, *, prf_hz: float, n_pulses: int, seed: int) -> ModelExtensions:
        """The extensions that act inside :func:`microdoppler.synthesis.synthesize`
        (``SynthesisConfig.extensions``: envelope gain, blade and body hooks; None where
        not in use) for a record of ``n_pulses`` at ``prf_hz``. Two causes filling one
        slot act one after the other (gains multiply)."""
        if not prf_hz > 0:
            raise ValueError(f"prf_hz={prf_hz} must be > 0")
        if n_pulses < 0:
            raise ValueError(f"n_pulses={n_pulses} must be >= 0")
        kw = {}
        dur = n_pulses / prf_hz
        for spec, p in self._named():
            for slot, fn in spec.model_extension(p, duration_s=dur, seed=seed).items():
                kw[slot] = fn if slot not in kw else _chain(slot, kw[slot], fn)
        return ModelExtensions(**kw)

    def blade_amplitudes(self, n_blades: int) -> np.ndarray | None:
        """Each blade's scattering amplitude (float [n_blades]; None when no named
        cause makes the blades unequal, e.g. ``blade_imbalance``)."""
        for spec, p in self._named():
            a = spec.blade_amplitudes(p, n_blades)
            if a is not None:
                return a
        return None

    def post(self, iq: np.ndarray, *, prf_hz: float, seed: int) -> np.ndarray:
        """Post-step on the synthesised echo (phase noise); returns a new array
        (complex64 [n_pulses]), or ``iq`` itself when no post-step is in use."""
        for spec, p in self._named():
            iq = spec.post(p, iq, prf_hz=prf_hz, seed=seed)
        return iq

    def to_dict(self) -> dict:
        return {"schema": SCHEMA, "extensions": {c: dict(p) for c, p in self.effects.items()}, "meta": dict(self.meta)}


def read_yaml(path, expected: str):
    """The parsed YAML file at ``path`` ({} when empty); a missing file or one that is
    not YAML is an :class:`InputError` naming ``expected``."""
    path = Path(path)
    if not path.exists():
        raise InputError(path, "file", "does not exist", expected)
    try:
        return yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as exc:
        raise InputError(path, "file", f"is not YAML ({type(exc).__name__})", expected) from None


def load_extensions(path_yaml) -> ExtensionSet:
    """Read an extensions YAML (as written by :func:`~microdoppler.causes.save_extensions`).

    Parameters
    ----------
    path_yaml : str or path-like
        The YAML file (``schema: extensions/1``).

    Returns
    -------
    ExtensionSet
        The extensions with their parameters and ``meta``.

    Raises
    ------
    microdoppler.errors.InputError
        Naming the file and the field (a missing file, a wrong schema, an unknown cause).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from microdoppler.causes import ExtensionSet, load_extensions, save_extensions
    >>> path = save_extensions(ExtensionSet({"motor_speed_scale": {"scale": 1.02}}),
    ...                        Path(tempfile.mkdtemp()) / "extended.yaml")
    >>> load_extensions(path).effects
    {'motor_speed_scale': {'scale': 1.02}}
    """
    path = Path(path_yaml)
    return extensions_from_dict(read_yaml(path, f"an {SCHEMA} YAML file"), path)


def extensions_from_dict(d, path) -> ExtensionSet:
    """An ``extensions/1`` mapping (read from ``path``, named in errors) -> ExtensionSet."""
    if not isinstance(d, dict) or d.get("schema") != SCHEMA:
        raise InputError(path, "schema", f"is {d.get('schema') if isinstance(d, dict) else d!r}", repr(SCHEMA))
    ext = d.get("extensions") or {}
    if not isinstance(ext, dict):
        raise InputError(path, "extensions", f"is a {type(ext).__name__}", "a mapping cause -> params")
    return ExtensionSet({c: check_params(c, p, source=path) for c, p in ext.items()}, d.get("meta") or {})


def save_extensions(ext: ExtensionSet, path_yaml) -> Path:
    """Write ``ext`` as YAML, atomically (temporary sibling, then rename).

    Parameters
    ----------
    ext : ExtensionSet
        The extensions with their parameters and ``meta``.
    path_yaml : str or path-like
        The file to write (``schema: extensions/1``).

    Returns
    -------
    pathlib.Path
        ``path_yaml``.

    See Also
    --------
    load_extensions

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from microdoppler.causes import ExtensionSet, save_extensions
    >>> path = save_extensions(ExtensionSet({"sideband_asymmetry": {"asymmetry_db": 3.0}}),
    ...                        Path(tempfile.mkdtemp()) / "extended.yaml")
    >>> print(path.read_text().splitlines()[0])
    schema: extensions/1
    """
    path = Path(path_yaml)
    with atomic_file(path) as tmp:
        tmp.write_text(yaml.safe_dump(yaml_plain(ext.to_dict()), sort_keys=False))
    return path


def yaml_plain(x):
    """Mappings, sequences and numpy scalars -> plain Python (YAML-safe)."""
    if isinstance(x, Mapping):
        return {str(k): yaml_plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [yaml_plain(v) for v in x]
    if isinstance(x, np.generic):
        return x.item()
    return x


def _chain(slot: str, first, second):
    """Two extensions of one :class:`ModelExtensions` slot, one after the other."""
    if slot == "envelope_gain":
        return lambda f_hz: first(f_hz) * second(f_hz)

    def hook(i0, i1, t_s, x):
        first(i0, i1, t_s, x)
        second(i0, i1, t_s, x)

    return hook
