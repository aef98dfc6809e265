"""
Read a recording and draw its spectrogram
=========================================

A recording is a flight-zarr/1 store (:doc:`/format`), read into a
:class:`~microdoppler.io.Flight` by :func:`~microdoppler.io.read_flight`. Here the
store is written first, from the measurement emulator: 6 s of an Inspire 2 on a
straight leg 600 m from the paper's radar (1.35 GHz, 7.3 kHz PRF).
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

from microdoppler.emulator import FlightSpec, emulate_flight
from microdoppler.io import read_flight, write_flight
from microdoppler.spectra import spectrogram

folder = Path(tempfile.mkdtemp())
spec = FlightSpec(
    "inspire_demo",
    "drone",
    drone_model="inspire2",
    duration_s=6.0,
    mean_range_m=600.0,
    path="straight",
    snr_db=40.0,
    seed=1,
)
path = write_flight(folder / "inspire_demo.zarr", emulate_flight(spec)[0])

# %%
# Read the store back: the I/Q samples, the radar's parameters and the motor log.
flight = read_flight(path)
print(
    f"{flight.attrs['flight_id']}: {flight.iq.size} pulses at {flight.prf_hz:g} Hz, "
    f"carrier {flight.carrier_hz / 1e9:.2f} GHz, motor log: {flight.has_motor_log}"
)

# %%
# The paper's spectrogram (:func:`~microdoppler.spectra.spectrogram`): a 15 Hz
# high-pass, 4096-point Blackman-Harris windows with 50 % overlap, the central 480
# Doppler bins. The body is the strong line; the rotors' HERM lines stand either side.
sg = spectrogram(flight.iq, flight.prf_hz)
fig, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
mesh = ax.pcolormesh(sg.time_s, sg.doppler_hz, sg.power_db.T, shading="nearest", cmap="viridis")
fig.colorbar(mesh, ax=ax, label="power [dB]")
ax.set(xlabel="time [s]", ylabel="Doppler [Hz]", title="Inspire 2, emulated, 1.35 GHz")
plt.show()
