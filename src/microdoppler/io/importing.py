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


def import_recording(
    path,
    *,
    options: dict | None = None,
    sidecar: dict | None = None,
    layout: str | None = None,
    variable: str | None = None,
    default_flight_id: str | None = None,
    background=None,
    force: bool = False,
) -> tuple[Flight, list[str]]:
    """Read ``path`` and return ``(flight, warnings)``.

    ``options`` and ``sidecar`` map keys of
    ``microdoppler.io.recordings.SIDECAR_KEYS`` to ``(value, label)`` (the label
    names the option, table cell or sidecar key in messages); options win over the
    sidecar, both over the file's metadata. The track is the first of: ``track`` (CSV
    path) or ``range_m`` (constant, a staring recording) among the options, then the
    sidecar's, then the file's own track arrays or ``range_m``. ``background`` names a
    target-free recording of the same cells (same format and layout), stored as
    ``background/iq`` and used for the I/Q balance; the options' or sidecar's
    ``noise_segment_s`` names a target-free stretch of the recording.

    A raw FMCW cube (FMCW parameters given, or a file that states them) is turned into
    the target's slow time and track first (``microdoppler.io.fmcw_files.import_fmcw``).

    Parameters
    ----------
    path : str or path-like
        The recording: SigMF, MATLAB ``.mat``, NumPy ``.npz`` or ``.npy``.
    options, sidecar : dict, optional
        ``{key: (value, label)}``: the radar's and target's parameters (``prf_hz``
        [Hz], ``carrier_hz`` [Hz], ``target``, ``radar_id``, the rotor geometry, ...).
    layout : str, optional
        How I/Q is stored (``complex``, ``interleaved``, ...); default from the file.
    variable : str, optional
        The array holding the samples in a ``.mat`` or ``.npz`` file.
    default_flight_id : str, optional
        The flight id when neither the file nor the options name one (default: the
        file's stem).
    background : str or path-like, optional
        A target-free recording of the same cells.
    force : bool
        Keep a set-up that fails the plausibility check, with the warnings stored in
        the flight's ``plausibility_warnings`` attribute (and in the warnings
        returned), instead of raising.

    The declared set-up is checked against physics and the recording
    (``microdoppler.io.plausibility.check_setup``) before anything is returned.

    Returns
    -------
    flight : Flight
        The flight (``iq`` complex64 [n_pulses], a track, the attributes).
    warnings : list of str
        What the import noticed and could not fix (I/Q imbalance, ...).

    Raises
    ------
    microdoppler.errors.InputError
        Naming the file, the field and what was expected (a parameter missing
        everywhere, an unreadable file, an implausible set-up without ``force``, ...).

    See Also
    --------
    write_flight, read_flight

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from microdoppler.io import import_recording
    >>> path = Path(tempfile.mkdtemp()) / "stand.npz"
    >>> rng = np.random.default_rng(0)
    >>> np.savez(path, iq=(rng.standard_normal(5000) + 1j * rng.standard_normal(5000)).astype(np.complex64))
    >>> params = dict(prf_hz=5000.0, carrier_hz=3.3e9, target="drone", radar_id="cw_s_band", range_m=25.0,
    ...               drone_model="quad", n_motors=4, n_blades=2, blade_length_m=0.12)
    >>> flight, warnings = import_recording(path, options={k: (v, k) for k, v in params.items()})
    >>> flight.flight_id, flight.prf_hz, flight.iq.shape
    ('stand', 5000.0, (5000,))
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
            raise InputError(
                path,
                "--layout",
                f"is {layout!r} for an FMCW cube",
                "no --layout (a real cube is a real beat signal, a complex one I/Q)",
            )
        flight, warns = import_fmcw(
            path,
            *read,
            options=options,
            sidecar=sidecar,
            variable=variable,
            default_flight_id=default_flight_id,
            background=background,
            noise_s=noise_s,
        )
    else:
        flight, warns = import_slow_time(
            path,
            read,
            options=options,
            sidecar=sidecar,
            layout=layout,
            variable=variable,
            default_flight_id=default_flight_id,
            background=background,
            noise_s=noise_s,
        )
    implausible = check_setup(path, flight.attrs, len(flight.iq), force=force)
    return mark(flight, implausible), warns + implausible
