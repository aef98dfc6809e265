"""microdoppler: synthetic drone micro-Doppler for bird/drone classification.

Modules follow the paper (White, Jahangir, Baker, Antoniou):

- ``radar``        radar and drone parameters (Table I, Table II)
- ``flightzarr``   the flight-zarr/1 exchange format: read, write, validate
- ``motorlog``     motor-log ingest (PX4 ULog, CSV)
- ``sampling``     motor-speed sampling variants (§V.A.1)
- ``synthesis``    thin-wire blades (eq. 1) and body/blade/alpha model (eq. 2)
- ``spectrogram``  15 Hz high-pass, 4096-point Blackman-Harris STFT, tiles
- ``snr``          the one SNR measure used everywhere
"""

__version__ = "0.1.0"
