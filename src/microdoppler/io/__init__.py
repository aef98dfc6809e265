"""Input and output: the flight-zarr/1 format, motor logs, readers of recordings from other tools, atomic outputs.

Turning a recording into a checked flight (FMCW processing, I/Q balance, plausibility)
is :mod:`microdoppler.importing`."""

from .flightzarr import Flight, read_flight, validate_store, write_flight
from .motorlog import MotorLog, read_motor_log

__all__ = ["Flight", "read_flight", "write_flight", "validate_store", "MotorLog", "read_motor_log"]
