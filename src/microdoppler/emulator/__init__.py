"""The measurement emulator: the measured world the pipeline is trained, tested and
diagnosed against (issue 3). See :mod:`.world` for the API."""

from .world import FlightSpec, emulate_flight, measured_snr_db
from .profiles import PROFILES, emulate_world, plan_world

__all__ = ["FlightSpec", "emulate_flight", "measured_snr_db", "plan_world", "emulate_world", "PROFILES"]
