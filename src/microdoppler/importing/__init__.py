"""Importing recordings made by other tools (``microdoppler import``): from what a reader
of :mod:`microdoppler.io` returns to a checked flight-zarr/1 flight. The FMCW range
processing (:mod:`~microdoppler.importing.fmcw`), the receiver's I/Q balance
(:mod:`~microdoppler.importing.iqbalance`), the plausibility checks of a declared set-up
(:mod:`~microdoppler.importing.plausibility`) and the steps that join them
(:mod:`~microdoppler.importing.flight`)."""

from .flight import import_recording

__all__ = ["import_recording"]
