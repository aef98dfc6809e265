"""The measurement emulator: the measured world the pipeline is trained, tested and
diagnosed against. Nothing downstream may depend on data coming from here.

Public API
----------
``FlightSpec``            frozen dataclass defining one flight (see :mod:`.world`)
``emulate_flight(spec)``  -> (flightzarr.Flight, truth dict); deterministic in ``spec.seed``
``plan_world(profile, seed)`` -> list[FlightSpec]
``emulate_world(profile, seed, out_dir, *, key_path=None, progress=True, workers=None, specs=None)``
``measured_snr_db(flight)`` the pipeline's SNR (snr.flight_snr_db on spectrogram.spectrogram)

Modules: :mod:`.world` (flights), :mod:`.profiles` (test/default/paper, writing a world),
:mod:`.drone` (loop paths, motor dynamics at 200 Hz -> pulse rate, log writer),
:mod:`.bird` (bodies + flapping wings, flocks), :mod:`.background` (clutter, noise,
phase noise, artifacts, SNR model), :mod:`.radars` (radar 1 / radar 2), :mod:`.knobs`
(the catalog's causes), :mod:`.calibration` (motor statistics vs the real PX4 log,
per-class SNR vs Table III).

Physics beyond the paper's simulator: per-motor static offsets, manoeuvre, trim, gust
and controller moments, ESC lag; tapered blade current (nested thin wires of the
synthesis kernel) plus a sideband roll-off; slow body-aspect and blade variations;
range-cell straddle loss; cell-by-cell urban clutter with wind-blown spectra; oscillator
phase noise (radar 2 stronger); radar-2 artifacts; noisy tracker output; birds.

Conventions
-----------
- ``FlightSpec.snr_db`` is the body line's expected spectrogram SNR (peak over median
  floor, thermal noise only). Measured values are ~3-6 dB lower for a drone on a straight leg
  (speed wander smearing the line, straddle, aspect, clutter) and lower still when the body Doppler sits in
  the 15 Hz high-pass notch.
- ``first_sideband_db`` is the per-motor-line amplitude below the body in the model;
  the measured first sideband group sits ~0.5-2 dB closer to the body.
- Knobs follow :mod:`microdoppler.causes.catalog` exactly. The ``phase_noise`` knob is an
  episode of the flight recording: ``iq`` carries it, ``background/iq`` (another time)
  does not. The radars' own (weaker, Lorentzian) phase noise is in both.
- Drones of the ``default`` and ``paper`` worlds are flown by a few airframes per model
  (``FlightSpec.airframe``); about one in three large-model airframes carries an unequal
  blade (``blade_imbalance``, 3-10 dB) on every flight it flies (:mod:`.profiles`).
- Mini flights have no motor log (the paper's Mini had none); Inspire logs at 30 Hz,
  Matrice at 20 Hz, jittered stamps, 1 % dropped rows, 1 rpm quantisation.
"""

from .profiles import PROFILES, emulate_world, plan_world
from .world import FlightSpec, emulate_flight, measured_snr_db

__all__ = ["FlightSpec", "emulate_flight", "measured_snr_db", "plan_world", "emulate_world", "PROFILES"]
