"""Diagnosis: what the paper's simulation gets wrong about a measured drone flight.

``diagnose_flight(flight, *, motor_log=None, config=None) -> dict`` returns one report
entry (``shared/formats/flight-zarr.md``, ``diagnosis-report/2``) or raises
:class:`Undiagnosable`; ``diagnose(paths, out_json)`` writes the report, every flight
in it (``skipped`` with a reason where it cannot be diagnosed);
``aggregate(report) -> ExtensionSet`` turns the training flights' diagnosis into the
``extended`` synthetic variant.
"""

from .core import (REPORT_SCHEMA, DiagnosisConfig, Undiagnosable, decide, decide_all, diagnose, diagnose_flight,
                   run_tests, write_json)
from .aggregate import aggregate

__all__ = ["DiagnosisConfig", "diagnose_flight", "diagnose", "aggregate", "run_tests", "decide", "decide_all", "write_json",
           "Undiagnosable", "REPORT_SCHEMA"]
