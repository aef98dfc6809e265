"""Input and output: the flight-zarr/1 format, motor logs, recordings from other tools, atomic outputs."""
