"""The catalog's causes as plugins: one module per cause, one interface, one registry.

Each cause of the catalog (a way the measured flights differ from the paper's
simulation) lives in one module here (:mod:`.sideband_asymmetry`,
:mod:`.sideband_fading`, :mod:`.body_fluctuation`, :mod:`.motor_log_lag`,
:mod:`.motor_speed_scale`, :mod:`.phase_noise`, :mod:`.blade_imbalance`), which
defines ``CAUSE``, an instance of :class:`~.base.CauseSpec`: its catalog parameters
and units, the observations its test reads from the shared measurement
(:mod:`.measure`), its held-out test (:mod:`.heldout`) and couplings, its relevance
margin, its extension of the twins (:mod:`.extensions`), its effect in the emulator
and its panel in the diagnosis figure. :mod:`.registry` lists them in the catalog's
order; :func:`register` adds one. The diagnosis (:mod:`microdoppler.diagnosis`), the
twins and the emulator (:mod:`microdoppler.emulator`) iterate over the registry and
name no cause themselves. ``docs/adding-a-cause.md`` walks through one module.

The layer sits above :mod:`microdoppler.synthesis` and below the emulator and the
diagnosis: the shared measurement (:mod:`.measure`) and the diagnosis' settings
(:mod:`.config`) live here, so that a cause's test can read them.
"""

from .base import Cause, CauseSpec, Param
from .extensions import ExtensionSet, load_extensions, save_extensions
from .registry import get, names, register, specs, unregister

__all__ = [
    "Cause",
    "CauseSpec",
    "Param",
    "get",
    "names",
    "register",
    "specs",
    "unregister",
    "ExtensionSet",
    "load_extensions",
    "save_extensions",
]
