"""Statistics shared by every report: the flight-unit bootstrap."""

from .bootstrap import FlightDraws, draw_flights, interval, ratio_replicates

__all__ = ["draw_flights", "FlightDraws", "interval", "ratio_replicates"]
