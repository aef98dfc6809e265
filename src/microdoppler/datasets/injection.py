"""Stage ``inject_background`` (paper §V.A.3): a twin's target-only echo added to its
flight's ``background/iq``, the same resolution cells recorded with no target."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..errors import InputError
from ..io.flightzarr import read_flight
from .stores import flight_ids, open_store, put_array, writing_store

SYNTHETIC_SCHEMA = "twins/1"
INJECTED_SCHEMA = "injected/1"


#: offset of the background's phase-noise stream from the twin's seed
_BACKGROUND_STREAM = 7919


def inject(target_iq: np.ndarray, background_iq: np.ndarray, source: str = "twin", *,
           effects: dict | None = None, prf_hz: float | None = None, seed: int = 0) -> np.ndarray:
    """Sum of the simulated target and the recorded background, complex64 [n_pulses].

    ``effects`` (a twin's extensions, ``{cause: params}``): with ``phase_noise`` the
    radar's extra phase noise also acts on the background, as it acts on everything
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
        Pulse repetition frequency [Hz]; needed with ``phase_noise``.
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
    fit_twin

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
    if effects and "phase_noise" in effects:
        from ..synthesis.extensions import ExtensionSet

        if prf_hz is None:
            raise ValueError("inject: prf_hz is needed to apply phase noise to the background")
        pn = ExtensionSet({"phase_noise": dict(effects["phase_noise"])})
        bg = pn.post(bg, prf_hz=float(prf_hz), seed=(int(seed) + _BACKGROUND_STREAM) % 2 ** 31)
    return (np.asarray(target_iq, np.complex64) + bg).astype(np.complex64)


def build_injected(measured_dir, synthetic_zarr, out, *, log=print) -> pd.DataFrame:
    """Write ``results/injected/{variant}.zarr``: group per twin with ``iq`` = twin + background."""
    syn = open_store(synthetic_zarr, SYNTHETIC_SCHEMA)
    rows = []
    with writing_store(out, {**dict(syn.attrs), "schema": INJECTED_SCHEMA}) as root:
        for fid in flight_ids(syn):
            g = syn[fid]
            flight = read_flight(f"{measured_dir}/{fid}.zarr")
            effects = dict(dict(g.attrs.get("extensions") or {}).get("effects") or {})
            iq = inject(np.asarray(g["iq"][...]), flight.background_iq, f"{measured_dir}/{fid}.zarr",
                        effects=effects, prf_hz=flight.prf_hz, seed=int(g.attrs.get("twin_seed", 0)))
            h = root.require_group(fid)
            h.attrs.update(dict(g.attrs))
            put_array(h, "iq", iq)
            rows.append(dict(flight_id=fid, n_pulses=len(iq)))
            log(f"{fid}: injected {len(iq)} pulses")
    return pd.DataFrame(rows, columns=["flight_id", "n_pulses"])
