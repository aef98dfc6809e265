"""The any-radar generator, now :mod:`microdoppler.examples` (the documentation's
examples use it too); the tests and benchmarks import it from here."""

from microdoppler.examples import (  # noqa: F401
    CARRIERS_HZ,
    VISIBLE_DB,
    Case,
    draw_case,
    make_recording,
    rotor_line_spacing_hz,
    true_cpi_means,
)
