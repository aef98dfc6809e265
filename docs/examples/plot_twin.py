"""
Build the twin of a flight
==========================

A twin is the paper's model driven by the flight's logged rotor speeds (here the
``sub_cpi`` sampling variant, :func:`~microdoppler.rotors.resample`) and calibrated to
the flight's body and sideband SNRs by :func:`~microdoppler.datasets.fit_twin`;
:func:`~microdoppler.datasets.inject` adds the recorded background.
"""

import matplotlib.pyplot as plt

from microdoppler.datasets import fit_twin, inject
from microdoppler.emulator import FlightSpec, emulate_flight
from microdoppler.io import MotorLog
from microdoppler.rotors import resample
from microdoppler.spectra import SpectrogramConfig, spectrogram

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
flight = emulate_flight(spec)[0]
log = MotorLog(flight.motors_time_s, flight.motors_rpm)
twin_rev_s = resample("sub_cpi", log, len(flight.iq), flight.prf_hz)
twin_iq, fit = fit_twin(flight, twin_rev_s, log, spec_cfg=SpectrogramConfig(), seed=0)
twin = inject(twin_iq, flight.background_iq)
print(
    f"fit {fit['status']}: alpha {fit['alpha_s'] * 1e3:.2f} ms, S_body {fit['s_body']:.3g}, "
    f"S_blade {fit['s_blade']:.3g}"
)

# %%
# The measured flight and its twin, side by side on the same colour scale.
fig, axes = plt.subplots(1, 2, figsize=(8, 3.5), sharey=True, layout="constrained")
for ax, (title, iq) in zip(axes, [("emulated measurement", flight.iq), ("twin (sub_cpi)", twin)]):
    sg = spectrogram(iq, flight.prf_hz)
    mesh = ax.pcolormesh(sg.time_s, sg.doppler_hz, sg.power_db.T, shading="nearest", vmin=-60, vmax=0)
    ax.set(xlabel="time [s]", title=title)
axes[0].set_ylabel("Doppler [Hz]")
fig.colorbar(mesh, ax=axes, label="power [dB]")
plt.show()
