"""Statistics shared by every report: the flight-unit bootstrap."""
