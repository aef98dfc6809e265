"""The catalog of discrepancies between measured flights and the paper's simulation.

Each cause's *parameters* (names, units, signs, detectable ranges) are defined in its
own module (:mod:`microdoppler.causes`); :data:`CAUSES` is the registry's view of them,
led by ``none`` (the paper's model explains the flight). The measurement emulator
implements the causes with its own physics (``microdoppler.emulator``); the diagnosis
fits model extensions with the same parameter names (:mod:`.extensions`), so a fitted
value can be compared with the emulator's truth. See ``shared/formats/flight-zarr.md``.
"""

from __future__ import annotations

from collections.abc import Mapping

from . import registry
from .base import Cause, Param  # noqa: F401 (re-exported)
from .phase_noise import (
    PHASE_NOISE_BANDWIDTH_HZ,
    SKIRT_OFFSET_HZ,
    flat_rms_rad,  # noqa: F401 (re-exported)
    flat_skirt_dbc_hz,
)

NONE = Cause("none", "the paper's model explains the flight", ())
#: not a model extension: the model, with every named cause's extension, still misses
#: the held-out data by more than noise and the fit's uncertainty allow. Reported last,
#: so that "none" always means that the model fits.
UNEXPLAINED = "unexplained"


class _Causes(Mapping):
    """name -> :class:`Cause`: ``none``, then the registered causes in order (read at
    every access, so a cause registered later is in it)."""

    def _all(self) -> dict:
        return {NONE.name: NONE, **{s.name: s.entry for s in registry.specs()}}

    def __getitem__(self, name):
        return self._all()[name]

    def __iter__(self):
        return iter(self._all())

    def __len__(self):
        return len(self._all())

    def __repr__(self):
        return f"CAUSES({list(self)})"


CAUSES: Mapping = _Causes()


def catalog() -> tuple:
    """Every name a report may give: ``none``, the registered causes, ``unexplained``."""
    return tuple(CAUSES) + (UNEXPLAINED,)


def __getattr__(name):
    # CATALOG follows the registry (a module attribute computed at access)
    if name == "CATALOG":
        return catalog()
    raise AttributeError(name)
