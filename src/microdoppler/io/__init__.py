"""Input and output: the flight-zarr/1 format, motor logs, recordings from other tools, atomic outputs."""

from .flightzarr import Flight, read_flight, validate_store, write_flight
from .importing import import_recording
from .motorlog import MotorLog, read_motor_log

__all__ = ["Flight", "read_flight", "write_flight", "validate_store", "import_recording", "MotorLog", "read_motor_log"]
