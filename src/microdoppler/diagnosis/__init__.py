"""Diagnosis: what the paper's simulation gets wrong about a measured drone flight.

One flight passes four steps, one module each, in this order (:mod:`.pipeline`'s
``diagnose_flight``):

1. :mod:`.measure`: the flight against the paper's model of it, every spectrogram
   product the tests need in one :class:`Measurements` (or :class:`Undiagnosable`);
2. :mod:`.hypotheses`: one held-out likelihood test per catalog cause;
3. :mod:`.decide`: the causes named (greedy, step-wise Bonferroni) and the report entry;
4. :mod:`.explain`: the figure.

:mod:`.config` holds the settings (:class:`DiagnosisConfig`: its keys and its fixed settings).
``diagnose_flight(flight, *, motor_log=None, config=None) -> dict`` returns one report
entry (``shared/formats/flight-zarr.md``, ``diagnosis-report/2``) or raises
:class:`Undiagnosable`; ``diagnose(paths, out_json)`` writes the report, every flight
in it (``skipped`` with a reason where it cannot be diagnosed);
``aggregate(report) -> ExtensionSet`` (:mod:`.aggregate`) turns the training flights'
diagnosis into the ``extended`` synthetic variant.
"""

from .config import DiagnosisConfig
from .measure import Measurements, Undiagnosable, measure
from .hypotheses import TestResults, run_tests
from .decide import Decision, decide, decide_all, decide_flight
from .explain import plot_diagnosis
from .aggregate import aggregate
from .pipeline import REPORT_SCHEMA, diagnose, diagnose_flight, write_json

__all__ = [
    "DiagnosisConfig",
    "diagnose_flight",
    "diagnose",
    "aggregate",
    "measure",
    "Measurements",
    "run_tests",
    "TestResults",
    "decide",
    "decide_all",
    "decide_flight",
    "Decision",
    "plot_diagnosis",
    "write_json",
    "Undiagnosable",
    "REPORT_SCHEMA",
]
