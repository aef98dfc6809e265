"""The interface of a cause: its catalog entry (:class:`Param`, :class:`Cause`) and
:class:`CauseSpec`, the one object a cause module defines (as ``CAUSE``).

A cause module (one per cause, see ``docs/adding-a-cause.md``) subclasses
:class:`CauseSpec` and fills in what it owns:

- the catalog entry: ``name``, ``meaning``, ``params`` (names, units, signs,
  detectable ranges);
- the diagnosis: ``observations`` (the fields of the shared
  ``microdoppler.causes.measure.Measurements`` its test reads), ``line`` (the
  line its test needs: ``"body"``, ``"rotor"`` or ``""``), its held-out
  :meth:`~CauseSpec.test`, its couplings (``test_partners``, ``reads_sidebands``,
  ``floor_partner``) and its relevance margin (``margin_field``);
- the twins' extension: :meth:`~CauseSpec.complete_params`,
  :meth:`~CauseSpec.transform_log`, :meth:`~CauseSpec.model_extension`,
  :meth:`~CauseSpec.blade_amplitudes`, :meth:`~CauseSpec.post`;
- the emulator's effect: :meth:`~CauseSpec.world_params` and the ``world_*`` hooks;
- the figure: :meth:`~CauseSpec.draw_panel` and the goodness-of-fit hooks.

Every hook has a default that does nothing, so a cause implements only what it
changes. Nothing here names a cause: the registry (:mod:`.registry`) lists them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class Param:
    name: str
    unit: str
    meaning: str
    detectable: str


@dataclass(frozen=True)
class Cause:
    name: str
    meaning: str
    params: tuple[Param, ...]

    @property
    def main_param(self) -> str:
        """The parameter the diagnosis must recover (first one)."""
        return self.params[0].name


def number(source, cause: str, k: str, x) -> float:
    """``x`` as a finite float, else an :class:`InputError` naming ``extensions.<cause>.<k>``."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InputError(source, f"extensions.{cause}.{k}", f"is {x!r}", "a number") from None
    if not np.isfinite(v):
        raise InputError(source, f"extensions.{cause}.{k}", f"is {v}", "a finite number")
    return v


class CauseSpec:
    """One cause of the catalog: everything the diagnosis, the twins, the emulator
    and the figure need of it (module doc). Subclass it in the cause's module and
    set ``CAUSE = YourCause()``.

    Examples
    --------
    >>> from microdoppler.causes import get
    >>> spec = get("blade_imbalance")
    >>> spec.name, [p.name for p in spec.params][:1]
    ('blade_imbalance', ['imbalance_db'])
    """

    # ------------------------------------------------------------ the catalog entry
    #: the cause's name (an identifier; the report, the twins and the emulator use it)
    name: str = ""
    #: what the cause is, in one line
    meaning: str = ""
    #: its parameters (``Param``); the first one is the one the diagnosis must recover
    params: tuple = ()

    # ------------------------------------------------------------ the diagnosis
    #: fields of the shared measurement (``microdoppler.causes.measure.Measurements``) the test reads
    observations: tuple = ()
    #: the line the test needs: "body" (not testable with the body in the clutter
    #: notch), "rotor" (the rotors' HERM lines: a flight where no rotor test is
    #: testable cannot be diagnosed) or ""
    line: str = ""
    #: causes whose extensions enter this cause's own test models once named
    #: (:meth:`test` takes them as ``given``)
    test_partners: frozenset = frozenset()
    #: the test reads sideband pairs whose local floor a named floor partner lifts;
    #: it is re-run with the partners in the floor's model (:meth:`floor_model`)
    reads_sidebands: bool = False
    #: with ``reads_sidebands``: read a pair where one side is clear of the floor partner's skirt
    clear_side: bool = False
    #: a named cause of this kind lifts the floor under the sidebands (:meth:`floor_model`)
    floor_partner: bool = False
    #: order in which floor partners enter the floor's model (lower first)
    floor_stage: int = 0
    #: the :class:`~microdoppler.causes.config.DiagnosisConfig` field of the relevance
    #: margin the test compares the fitted effect with (None: the cause's own constant)
    margin_field: str | None = None

    def test(self, M, cfg, fold, given: frozenset = frozenset()):
        """The held-out test (``microdoppler.causes.heldout.CauseTest``) of
        the measured flight ``M`` on the folds ``fold``, with the extensions of the
        named ``given`` (a subset of ``test_partners``) in both models."""
        raise NotImplementedError

    def untestable(self, M) -> str | None:
        """Why this flight cannot test the cause whatever its data (None: it can)."""
        return None

    def floor_available(self, test) -> bool:
        """Floor partners: whether the test ``test`` supports putting the cause in
        the floor's model of the sideband tests."""
        return False

    def floor_model(self, M, test, *, clear_side: bool = False):
        """Floor partners: ``M`` with the cause (as fitted by ``test``) in the model
        of the floor under the sidebands."""
        return M

    #: floor partners: whether :meth:`floor_model` depends on ``clear_side``
    floor_side_aware: bool = False

    def floor_evidence(self, n_new: int) -> dict:
        """Floor partners: evidence added to a sideband test read with the cause in
        the floor's model (``n_new``: sideband pairs it kept)."""
        return {}

    # ------------------------------------------------------------ the twins' extension
    #: secondary parameters filled in when not given (e.g. older files)
    defaults: Mapping = {}
    #: (parameter, ">= 0" or "> 0") bounds of the twins' parameters
    bounds: tuple = ()

    def extra_params(self, params: dict) -> dict:
        """Pops and returns the parameters that are no catalog parameters but the
        extension may carry (e.g. a measured shape); {} by default."""
        return {}

    def complete_params(self, params: dict, source) -> None:
        """Fill in missing parameters of ``params`` in place (defaults by default)."""
        for k, v in self.defaults.items():
            params.setdefault(k, v)

    def check_extra(self, extra: dict, source) -> dict:
        """Validate what :meth:`extra_params` popped."""
        return extra

    def transform_log(self, p, t, rpm):
        """(time [s], rpm) of the motor log with the extension: unchanged by default."""
        return t, rpm

    def model_extension(self, p, *, duration_s: float, seed: int) -> dict:
        """Slots of ``microdoppler.synthesis.model.ModelExtensions``
        (``envelope_gain``, ``blade_hook``, ``body_hook``) the extension fills."""
        return {}

    def blade_amplitudes(self, p, n_blades: int):
        """Each blade's scattering amplitude (float [n_blades]); None: alike."""
        return None

    def post(self, p, iq, *, prf_hz: float, seed: int):
        """Post-step on the synthesised echo; returns ``iq`` itself when none."""
        return iq

    #: the post-step acts on everything the radar receives (the injected background too)
    acts_on_background: bool = False

    # ------------------------------------------------------------ the emulator's effect
    #: defaults of secondary parameters of the emulator's knob
    world_defaults: Mapping = {}

    def world_params(self, full: dict) -> dict:
        """The knob's parameters completed and checked (ValueError); ``full`` has the
        defaults merged in, the values not yet converted."""
        return full

    def world_check(self, full: dict) -> None:
        """Range checks of the knob's float parameters (ValueError)."""

    def world_envelope(self, p):
        """``envelope(f_hz) -> gain`` (float32) on the blade signal; None: none."""
        return None

    def world_blade_gain(self, p, duration_s: float, rng):
        """A slow gain on the blade signal (``amplitude(t_s)``), drawn from ``rng``; None: none."""
        return None

    def world_body_gain(self, p, duration_s: float, rng):
        """A slow gain on the body amplitude, drawn from ``rng`` (after the blade gains); None: none."""
        return None

    def world_blade_amplitudes(self, p, n_blades: int):
        """Per-blade amplitudes (tuple [n_blades]); None: alike."""
        return None

    def world_log(self, p) -> dict:
        """Keyword arguments of the motor log's writer (``lag_s``, ``scale``)."""
        return {}

    def world_phase_rms(self, p) -> float | None:
        """rms [rad] of a flat phase error on the whole flight echo; None: none."""
        return None

    # ------------------------------------------------------------ the figure
    def draw_panel(self, ax, test) -> None:
        """The diagnosis figure's statistic panel when this cause is shown."""
        s = test.series
        ax.plot(s["t_s"], s["stat"], ".", ms=3, label="measured")
        ax.plot(s["t_s"], s["base"], "k-", label="baseline")
        ax.plot(s["t_s"], s["ext"], "r-", label="extended")
        ax.legend(fontsize=8)

    def calibration_measurement(self, M):
        """Named: the measurement the model is calibrated on for the figure and the
        goodness of fit (unchanged by default)."""
        return M

    def gof_guard(self, guard_hz: float):
        """Named: (guard around the clutter line [Hz], skirt band (lo, hi) [Hz] or None)."""
        return guard_hz, None

    def gof_body_half(self, band_hz: float) -> float | None:
        """Named: half width [Hz] of the body's band left out of the goodness of fit
        (None: the default, half a band)."""
        return None

    # ------------------------------------------------------------ derived
    @property
    def entry(self) -> Cause:
        """The catalog entry."""
        return Cause(self.name, self.meaning, tuple(self.params))

    @property
    def param_names(self) -> list:
        return [p.name for p in self.params]

    def __repr__(self) -> str:
        return f"<cause {self.name}>"


def draw_band_panel(ax, test) -> None:
    """Statistic panel of a fluctuation: the series against the baseline's and the
    extension's 95 % bands."""
    s = test.series
    ax.plot(s["t_s"], s["stat"], ".", ms=3, label="measured")
    ax.fill_between(s["t_s"], -2 * s["base"], 2 * s["base"], alpha=0.3, label="baseline 95%")
    ax.plot(s["t_s"], 2 * s["ext"], "r--", lw=1, label="extended 95%")
    ax.plot(s["t_s"], -2 * s["ext"], "r--", lw=1)
    ax.legend(fontsize=8)
