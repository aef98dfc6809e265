"""
Simulate a drone for another radar
==================================

The paper's model (:func:`~microdoppler.synthesis.synthesize`) works for any radar:
here a quadcopter on a stand 25 m away, with 0.12 m blades at 160 rev/s, seen for 4 s
by a 3.3 GHz radar sampled at 5 kHz, with noise 30 dB below the body. The result is a
:class:`~microdoppler.io.Flight` that every other step reads.
"""

import matplotlib.pyplot as plt
import numpy as np

from microdoppler.io import Flight
from microdoppler.spectra import SpectrogramConfig, spectrogram
from microdoppler.synthesis import Radar, SynthesisConfig, Track, add_noise, synthesize

radar = Radar(prf_hz=5000.0, carrier_hz=3.3e9)
config = SynthesisConfig.of(prf_hz=radar.prf_hz, wavelength_m=radar.wavelength_m, n_blades=2, blade_length_m=0.12)
n_pulses = int(4.0 * radar.prf_hz)
rev_s = np.full((n_pulses, 4), 160.0, np.float32)
iq = add_noise(
    synthesize(config, Track.constant_velocity(25.0, 0.0, 4.0), rev_s, seed=0), noise_power=10 ** (-30 / 10), seed=1
)
track_s = np.linspace(0.0, 4.0, 41)
stand = Flight(
    attrs={
        "flight_id": "stand",
        "target": "drone",
        "radar_id": "s_band",
        "prf_hz": radar.prf_hz,
        "carrier_hz": radar.carrier_hz,
        "drone_model": "quad_stand",
        "n_motors": 4,
        "n_blades": 2,
        "blade_length_m": 0.12,
    },
    iq=iq,
    track_time_s=track_s,
    track_range_m=np.full(41, 25.0),
    track_radial_velocity_mps=np.zeros(41),
)
print(
    f"{stand.iq.size} pulses, blade tips at {2 * np.pi * 0.12 * 160:.0f} m/s, "
    f"tip Doppler {2 * 2 * np.pi * 0.12 * 160 / radar.wavelength_m:.0f} Hz (folded into +-{radar.prf_hz / 2:g} Hz)"
)

# %%
# Every Doppler bin of the 5 kHz band (``n_bins=0``), with a CPI of 2048 pulses: the
# blade-passing lines at multiples of 320 Hz reach past the Nyquist frequency and fold.
sg = spectrogram(stand.iq, stand.prf_hz, SpectrogramConfig(n_fft=2048, n_bins=0))
fig, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
ax.plot(sg.doppler_hz, sg.power_db.mean(axis=0), lw=0.8)
ax.set(xlabel="Doppler [Hz]", ylabel="mean power [dB]", title="quadcopter on a stand, 3.3 GHz, 5 kHz PRF")
plt.show()
