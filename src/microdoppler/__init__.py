"""microdoppler: synthetic drone micro-Doppler for bird/drone classification.

The folders follow the pipeline (White, Jahangir, Baker, Antoniou):

- ``io``          the flight-zarr/1 format, motor logs (PX4 ULog, CSV), recordings
                  from other tools, atomic outputs
- ``rotors``      motor-speed sampling variants (§V.A.1) and rotor speeds from the radar
- ``synthesis``   thin-wire blades (eq. 1), body/blade/alpha (eq. 2), the radar, the
                  catalog of model extensions
- ``spectra``     15 Hz high-pass, Blackman-Harris STFT (settings in seconds and Hz or m/s,
                  4096 points and 480 bins on the paper's radar); the one SNR measure
- ``stats``       the flight-unit bootstrap
- ``emulator``    the measured world (the embedded default)
- ``datasets``    split, twins, injection, tiles, fidelity (Table III, IV, VI)
- ``classifier``  the CNN over 9 seeds, Fig. 6, Table V, Fig. 12
- ``diagnosis``   what the simulation gets wrong on a measured flight
- ``commands``    the ``microdoppler`` command line
"""

__version__ = "0.2.0"
