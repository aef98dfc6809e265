"""The registry of causes: the cause modules in a fixed order (the catalog's), and
the public hook that adds one (:func:`register`).

Everything that iterates over the causes (the diagnosis' tests and decision, the
twins' extensions, the emulator's knobs, the figure) asks this registry at call
time, so a cause added with :func:`register` takes part everywhere. The built-in
causes are imported here by name, so that what a script can run is its import
closure (:mod:`microdoppler.codeversion`).
"""

from __future__ import annotations

from types import ModuleType

from . import (
    blade_imbalance,
    body_fluctuation,
    motor_log_lag,
    motor_speed_scale,
    phase_noise,
    sideband_asymmetry,
    sideband_fading,
)
from .base import CauseSpec

#: the built-in cause modules, in the catalog's order (the order of the tests, the
#: report's ``catalog`` and the twins' extensions)
BUILTIN: tuple = (
    sideband_asymmetry,
    sideband_fading,
    body_fluctuation,
    motor_log_lag,
    motor_speed_scale,
    phase_noise,
    blade_imbalance,
)
#: names that are no cause (the decision's outcomes)
RESERVED = ("none", "unexplained", "skipped")

_SPECS: list = [m.CAUSE for m in BUILTIN]


def register(source) -> CauseSpec:
    """Add a cause after the registered ones: a cause module (with a ``CAUSE``
    attribute) or a :class:`~.base.CauseSpec`. Returns the spec.

    Raises
    ------
    ValueError
        No spec, a name that is no identifier, reserved or already registered, or no
        parameter.

    Examples
    --------
    >>> from microdoppler.causes import CauseSpec, Param, names, register, unregister
    >>> class Toy(CauseSpec):
    ...     name = "toy_gain"
    ...     meaning = "the whole echo a few dB stronger than the model says"
    ...     params = (Param("gain_db", "dB", "extra gain", "|gain_db| >= 1"),)
    >>> spec = register(Toy())
    >>> names()[-1]
    'toy_gain'
    >>> unregister("toy_gain")
    >>> "toy_gain" in names()
    False
    """
    spec = source.CAUSE if isinstance(source, ModuleType) else source
    if not isinstance(spec, CauseSpec):
        raise ValueError(f"register: {source!r} is no cause module (expected a CAUSE = CauseSpec subclass instance)")
    if not spec.name.isidentifier() or spec.name in RESERVED:
        raise ValueError(f"register: cause name {spec.name!r} must be an identifier other than {RESERVED}")
    if spec.name in names():
        raise ValueError(f"register: cause {spec.name!r} is already registered")
    if not spec.params:
        raise ValueError(f"register: cause {spec.name!r} has no parameter")
    _SPECS.append(spec)
    return spec


def unregister(name: str) -> None:
    """Remove a cause added with :func:`register` (a built-in one stays)."""
    if name in {m.CAUSE.name for m in BUILTIN}:
        raise ValueError(f"unregister: {name!r} is a built-in cause")
    _SPECS[:] = [s for s in _SPECS if s.name != name]


def specs() -> tuple:
    """Every registered cause's :class:`~.base.CauseSpec`, in order."""
    return tuple(_SPECS)


def names() -> tuple:
    """Every registered cause's name, in order."""
    return tuple(s.name for s in _SPECS)


def get(name: str) -> CauseSpec:
    """The registered cause ``name`` (KeyError when there is none)."""
    for s in _SPECS:
        if s.name == name:
            return s
    raise KeyError(name)
