"""One entry point for ``microdoppler import``: a recording of any supported kind ->
flight-zarr/1 (slow-time I/Q: :mod:`microdoppler.io.recordings`; raw FMCW cubes:
:mod:`microdoppler.io.fmcw_files`)."""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from .flightzarr import Flight
from .fmcw_files import import_fmcw
from .plausibility import check_setup, mark
from .recordings import _level_value, import_slow_time, wants_fmcw


def import_recording(path, *, options: dict | None = None, sidecar: dict | None = None,
                     layout: str | None = None, variable: str | None = None,
                     default_flight_id: str | None = None, background=None,
                     force: bool = False) -> tuple[Flight, list[str]]:
    """Read ``path`` and return ``(flight, warnings)``.

    ``options`` and ``sidecar`` map keys of
    :data:`~microdoppler.io.recordings.SIDECAR_KEYS` to ``(value, label)`` (the label
    names the option, table cell or sidecar key in messages); options win over the
    sidecar, both over the file's metadata. The track is the first of: ``track`` (CSV
    path) or ``range_m`` (constant, a staring recording) among the options, then the
    sidecar's, then the file's own track arrays or ``range_m``. ``background`` names a
    target-free recording of the same cells (same format and layout), stored as
    ``background/iq`` and used for the I/Q balance; the options' or sidecar's
    ``noise_segment_s`` names a target-free stretch of the recording.

    A raw FMCW cube (FMCW parameters given, or a file that states them) is turned into
    the target's slow time and track first (:func:`~microdoppler.io.fmcw_files.import_fmcw`).

    The declared set-up is checked against physics and the recording
    (:func:`~microdoppler.io.plausibility.check_setup`): an implausible one raises
    :class:`InputError`, or with ``force`` is kept with the warnings in the flight's
    ``plausibility_warnings`` attribute (and in the warnings returned).
    """
    options, sidecar = dict(options or {}), dict(sidecar or {})
    if layout is None:
        layout = _level_value(options, sidecar, "layout")
    if variable is None:
        variable = _level_value(options, sidecar, "variable")
    noise_s = _level_value(options, sidecar, "noise_segment_s")
    path = Path(path)
    fmcw, read = wants_fmcw(path, options, sidecar, variable)
    if fmcw:
        if layout is not None:
            raise InputError(path, "--layout", f"is {layout!r} for an FMCW cube",
                             "no --layout (a real cube is a real beat signal, a complex one I/Q)")
        flight, warns = import_fmcw(path, *read, options=options, sidecar=sidecar, variable=variable,
                                    default_flight_id=default_flight_id, background=background, noise_s=noise_s)
    else:
        flight, warns = import_slow_time(path, read, options=options, sidecar=sidecar, layout=layout,
                                         variable=variable, default_flight_id=default_flight_id,
                                         background=background, noise_s=noise_s)
    implausible = check_setup(path, flight.attrs, len(flight.iq), force=force)
    return mark(flight, implausible), warns + implausible
