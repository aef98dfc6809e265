"""A non-paper recording for the docs' end-to-end example: a quadcopter on a stand
(hovering, body at 0 Hz) seen by a 3.3 GHz CW radar sampled at 5 kHz for 12 s, one
blade of every rotor 6 dB weak, rotors at ~161 rev/s (0.12 m blades). Made by the
test suite's any-radar generator (``tests/any_radar.py``, no code shared with the
emulator or the synthesis); writes ``stand_3p3ghz.npz`` (array ``iq``) and
``stand.yaml`` (the sidecar) into the current folder.

    python docs/examples/make_stand_recording.py
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))
from any_radar import draw_case, make_recording  # noqa: E402

case = draw_case(7, duration_s=12.0, carrier_hz=3.3e9, prf_hz=5000.0, n_rotors=4, n_blades=2, blade_length_m=0.12,
                 tip_speed_mps=2 * np.pi * 0.12 * 160.0, setup="hover", weak_blade_db=6.0, body_snr_db=42.0,
                 radial_speed_mps=0.0)
flight, truth = make_recording(case)
np.savez("stand_3p3ghz.npz", iq=flight.iq)
Path("stand.yaml").write_text("prf_hz: 5000.0\ncarrier_hz: 3.3e9\ntarget: drone\nradar_id: cw_s_band\n"
                              "drone_model: quad_stand\nn_motors: 4\nn_blades: 2\nblade_length_m: 0.12\nrange_m: 25.0\n")
print(f"truth: mean rotor speed {np.mean(truth['rev_s']):.1f} rev/s, one blade {case.weak_blade_db:g} dB weak")
