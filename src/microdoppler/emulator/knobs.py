"""Reality knobs: the catalog's causes as physics of the emulated world.

Every registered cause (:mod:`microdoppler.causes`; ``none`` aside) can be switched on
per flight with the catalog's parameter names, units and signs. What a knob does is
its cause module's (:class:`~microdoppler.causes.base.CauseSpec`'s ``world_*`` hooks:
an envelope on the blade signal, a slow gain on the blades or on the body, unequal
blades, the motor log's lag and scale, a phase error on the whole flight echo);
:func:`validate_effects` completes and checks the parameters
(``world_defaults``, ``world_params``, ``world_check``) and
:func:`microdoppler.emulator.world.emulate_flight` applies them. A phase noise is an
episode of the flight recording: the target-free ``background/iq`` (recorded at
another time) does not carry it. The worlds carry a blade imbalance as a property of
an airframe (:mod:`.profiles`).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from ..causes import registry
from ..causes.blade_imbalance import imbalance_amplitudes  # noqa: F401 (re-exported)
from ..causes.body_fluctuation import BODY_FLUCTUATION_TAU_S  # noqa: F401 (re-exported)
from ..causes.catalog import CAUSES
from ..causes.phase_noise import PHASE_NOISE_BANDWIDTH_HZ
from ..causes.sideband_asymmetry import world_envelope as asymmetry_envelope  # noqa: F401 (re-exported)
from ..synthesis.processes import GAIN_DT_S, SlowGain, ou_process  # noqa: F401 (used here and re-exported)


def validate_effects(effects: Mapping | None) -> dict:
    """Check an ``{cause: {param: value}}`` mapping against the catalog.

    Returns a new dict with secondary parameters filled in. ``none`` may be given with
    no parameters and is dropped.
    """
    out: dict = {}
    for cause, params in dict(effects or {}).items():
        if cause not in CAUSES:
            raise ValueError(f"effect {cause!r} is not a catalog cause; expected one of {list(CAUSES)}")
        if cause == "none":
            if params:
                raise ValueError("effect 'none' takes no parameters")
            continue
        params = dict(params or {})
        names = [p.name for p in CAUSES[cause].params]
        for k in params:
            if k not in names:
                raise ValueError(f"effect {cause!r}: parameter {k!r} unknown; expected {names}")
        spec = registry.get(cause)
        full = spec.world_params({**spec.world_defaults, **params})
        for k in names:
            if k not in full:
                raise ValueError(f"effect {cause!r}: parameter {k!r} missing")
            v = float(full[k])
            if not np.isfinite(v):
                raise ValueError(f"effect {cause!r}: {k}={v} must be finite")
            full[k] = v
        spec.world_check(full)
        out[cause] = {k: full[k] for k in names}  # the catalog's order
    return out


def band_limited_phase(
    n: int,
    prf_hz: float,
    rms_rad: float,
    rng: np.random.Generator,
    *,
    bandwidth_hz: float = PHASE_NOISE_BANDWIDTH_HZ,
    corner_hz: float | None = None,
) -> np.ndarray:
    """Gaussian phase error theta [n] (float64, rad) with rms ``rms_rad``.

    Flat spectrum on |f| < ``bandwidth_hz`` (the catalog's phase-noise knob), or, with
    ``corner_hz``, a Lorentzian spectrum 1 / (1 + (f/corner)^2) (an oscillator's own
    noise). Generated in the frequency domain over the whole record (circular).
    """
    if rms_rad == 0 or n == 0:
        return np.zeros(n)
    import scipy.fft as sfft

    m = sfft.next_fast_len(n)
    f = sfft.rfftfreq(m, 1.0 / prf_hz)
    if corner_hz is None:
        shape = (f < bandwidth_hz).astype(np.float64)
    else:
        shape = 1.0 / np.sqrt(1.0 + (f / corner_hz) ** 2)
    shape[0] = 0.0
    spec = (rng.standard_normal(len(f)) + 1j * rng.standard_normal(len(f))) * shape
    th = sfft.irfft(spec, m, workers=1)[:n]
    s = th.std()
    return th * (rms_rad / s) if s > 0 else th
