"""The two staring radars of the emulated world (paper Table I, §III.A).

Both radars share Table I's waveform (PRF ~7.3 kHz, L-band, 4096-point STFT). They
differ as the paper describes: radar 2 is a later build with less gain (lower target
SNR), a stronger phase-noise profile (so strong clutter raises the floor of the cells
around it) and occasional spectral artifacts (impulsive interference and spurious
tones).

Phase noise here is the radar's *own* oscillator noise, present in every recording
(flight and background alike): theta(t) is Gaussian with a Lorentzian spectrum of
corner ``phase_noise_corner_hz`` and rms ``phase_noise_rms_rad``. The catalog's
``phase_noise`` knob adds a separate, flat, 100 Hz band-limited phase error on top of
it for a given flight (see :mod:`.knobs`).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..synthesis.radar import Radar


@dataclass(frozen=True)
class RadarSite:
    """One radar of the emulated world.

    Parameters
    ----------
    radar_id : str
    radar : Radar
        Waveform (PRF, carrier, STFT length).
    snr_offset_db : float
        Gain relative to radar 1 for every target [dB] (radar 2 is weaker).
    phase_noise_rms_rad : float
        RMS of the oscillator's phase error [rad].
    phase_noise_corner_hz : float
        Corner of its Lorentzian spectrum [Hz].
    clutter_cnr_db : tuple of float
        Range (low, high) of the per-cell stationary clutter-to-noise ratio per pulse [dB].
    artifact_rate_per_min : float
        Mean number of spectral artifacts per minute of recording.
    height_asl_m : float
        Antenna height above mean sea level [m] (informational, §III.A).
    """

    radar_id: str
    radar: Radar
    snr_offset_db: float
    phase_noise_rms_rad: float
    phase_noise_corner_hz: float
    clutter_cnr_db: tuple[float, float]
    artifact_rate_per_min: float
    height_asl_m: float

    def __post_init__(self):
        if self.phase_noise_rms_rad < 0:
            raise ValueError(f"phase_noise_rms_rad={self.phase_noise_rms_rad} must be >= 0")
        if not self.phase_noise_corner_hz > 0:
            raise ValueError(f"phase_noise_corner_hz={self.phase_noise_corner_hz} must be > 0")
        lo, hi = self.clutter_cnr_db
        if not lo <= hi:
            raise ValueError(f"clutter_cnr_db={self.clutter_cnr_db} must be (low, high) with low <= high")
        if self.artifact_rate_per_min < 0:
            raise ValueError(f"artifact_rate_per_min={self.artifact_rate_per_min} must be >= 0")


RADARS: dict[str, RadarSite] = {
    "radar1": RadarSite(
        "radar1",
        Radar(7300.0, 1.35e9, 4096),
        snr_offset_db=0.0,
        phase_noise_rms_rad=0.0015,
        phase_noise_corner_hz=20.0,
        clutter_cnr_db=(25.0, 55.0),
        artifact_rate_per_min=0.0,
        height_asl_m=176.0,
    ),
    "radar2": RadarSite(
        "radar2",
        Radar(7300.0, 1.35e9, 4096),
        snr_offset_db=-4.0,
        phase_noise_rms_rad=0.004,
        phase_noise_corner_hz=30.0,
        clutter_cnr_db=(25.0, 55.0),
        artifact_rate_per_min=2.0,
        height_asl_m=186.0,
    ),
}


def radar_site(radar_id: str) -> RadarSite:
    """The :class:`RadarSite` called ``radar_id`` (``radar1`` or ``radar2``)."""
    try:
        return RADARS[radar_id]
    except KeyError:
        raise ValueError(f"radar_id={radar_id!r} must be one of {sorted(RADARS)}") from None
