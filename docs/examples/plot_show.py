"""
Look at a recording: its spectrogram and rotor speeds
=====================================================

What ``microdoppler show STORE --out DIR`` draws and tabulates, from Python: the
docs' stand recording (:func:`microdoppler.examples.stand_recording`: a quadcopter on
a stand, 3.3 GHz, PRF 5 kHz, no motor log), its rotor speeds estimated from the radar
and stored as ``import --estimate-motors`` stores them, then
``microdoppler.views.plot_store`` (the figure) and
``microdoppler.views.rotor_table`` (the table, every number read from the store).
"""

import tempfile
from pathlib import Path

import matplotlib.image as mpimg
import matplotlib.pyplot as plt

from microdoppler.examples import stand_recording
from microdoppler.rotors import estimate_rotor_speeds
from microdoppler.views import plot_store, rotor_table, table_text

flight, truth, sidecar = stand_recording()
est = estimate_rotor_speeds(flight)
stored = est.with_flight(flight)  # motors/rpm and motors_radar, as the importer writes them
print(table_text(rotor_table(stored)))

# %%
# The figure: (a) the whole PRF with the blade tips' Doppler at the stored speeds
# (dashed), (b) the span the pipeline's images keep, (c) each rotor rank's speed over
# time with its ±2σ band.
png = plot_store(stored, Path(tempfile.mkdtemp()) / f"{flight.flight_id}.png")
fig, ax = plt.subplots(figsize=(9, 9.5), layout="constrained")
ax.imshow(mpimg.imread(png))
ax.set_axis_off()
plt.show()
