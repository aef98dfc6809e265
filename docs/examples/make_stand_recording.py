"""
Write the stand recording as a bare I/Q file
============================================

The recording of the end-to-end example in :doc:`/recordings` (a quadcopter on a stand
seen by a 3.3 GHz CW radar sampled at 5 kHz for 12 s, one blade of every rotor 6 dB
weak) as a tool outside the project would deliver it: ``stand_3p3ghz.npz`` (array
``iq``) and the sidecar ``stand.yaml``, written into the current folder. The echo is
:func:`microdoppler.examples.stand_recording`'s, drawn from the geometry with no code
shared with the paper's model. Run it as::

    python docs/examples/make_stand_recording.py
"""

from pathlib import Path

import numpy as np
import yaml

from microdoppler.examples import stand_recording

flight, truth, sidecar = stand_recording(seed=7, duration_s=12.0)
np.savez("stand_3p3ghz.npz", iq=flight.iq)
Path("stand.yaml").write_text(yaml.safe_dump(sidecar, sort_keys=False))
weak_db = truth["case"]["weak_blade_db"]
print(f"truth: mean rotor speed {np.mean(truth['rev_s']):.1f} rev/s, one blade {weak_db:g} dB weak")
