"""
Estimate rotor speeds from the radar
====================================

:func:`~microdoppler.rotors.estimate_rotor_speeds` reads each rotor's speed per CPI
from the HERM lines of the recording alone, then refines them with a least-squares fit
on the I/Q samples. The motor log of the emulated flight is not used by the estimate;
here it is the truth to compare against.
"""

import matplotlib.pyplot as plt
import numpy as np

from microdoppler.emulator import FlightSpec, emulate_flight
from microdoppler.rotors import estimate_rotor_speeds

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
est = estimate_rotor_speeds(flight)
print(est.summary())

# %%
# Each CPI's four speeds (ascending: ranks, not physical motors) with their 2-sigma
# bars, against the four logged motors' speeds.
fig, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
for m in range(flight.motors_rpm.shape[1]):
    ax.plot(
        flight.motors_time_s, flight.motors_rpm[:, m] / 60, color="0.7", lw=0.8, label="motor log" if m == 0 else None
    )
for r in range(est.speeds_rev_s.shape[1]):
    ax.errorbar(
        est.time_s, est.speeds_rev_s[:, r], yerr=2 * est.speeds_std_rev_s[:, r], fmt=".", ms=4, label=f"rank {r + 1}"
    )
ax.set(xlabel="time [s]", ylabel="rotor speed [rev/s]", xlim=(0, flight.iq.size / flight.prf_hz))
ax.legend(ncols=5, fontsize="small", loc="lower center")
plt.show()

# %%
# The mean speed per CPI against the log's mean over the same CPI.
logged = np.array([np.mean(flight.motors_rpm[np.abs(flight.motors_time_s - t) <= 0.28]) / 60 for t in est.time_s])
print(f"median relative error of the mean speed: {np.nanmedian(np.abs(est.common_rev_s / logged - 1)):.2%}")
