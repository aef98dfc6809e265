"""Radar and drone parameters (paper Table I and Table II)."""

from __future__ import annotations

from dataclasses import dataclass

SPEED_OF_LIGHT_MPS = 299_792_458.0


@dataclass(frozen=True)
class Radar:
    """Pulse-Doppler radar parameters.

    Parameters
    ----------
    prf_hz : float
        Pulse repetition frequency [Hz] (Table I: ~7.3 kHz).
    carrier_hz : float
        Carrier frequency [Hz] (L-band; 1.35 GHz gives lambda = 0.222 m, which
        matches the paper's "15 Hz high-pass removes speeds below 1.65 m/s").
    n_fft : int
        STFT length in pulses (one CPI, 4096).

    Raises
    ------
    ValueError
        When ``prf_hz`` or ``carrier_hz`` is not > 0, or ``n_fft`` is odd or < 2.

    See Also
    --------
    microdoppler.synthesis.SynthesisConfig

    Examples
    --------
    The paper's L-band radar and a 3.3 GHz radar at 5 kHz:

    >>> from microdoppler.synthesis import Radar
    >>> round(Radar().wavelength_m, 4), round(Radar().cpi_s, 3)
    (0.2221, 0.561)
    >>> radar = Radar(prf_hz=5000.0, carrier_hz=3.3e9)
    >>> round(radar.wavelength_m, 4), round(radar.doppler_hz(-1.0), 1)
    (0.0908, 22.0)
    """

    prf_hz: float = 7300.0
    carrier_hz: float = 1.35e9
    n_fft: int = 4096

    def __post_init__(self):
        if not self.prf_hz > 0:
            raise ValueError(f"prf_hz={self.prf_hz} must be > 0")
        if not self.carrier_hz > 0:
            raise ValueError(f"carrier_hz={self.carrier_hz} must be > 0")
        if self.n_fft < 2 or self.n_fft % 2:
            raise ValueError(f"n_fft={self.n_fft} must be an even integer >= 2")

    @property
    def wavelength_m(self) -> float:
        return SPEED_OF_LIGHT_MPS / self.carrier_hz

    @property
    def doppler_bin_hz(self) -> float:
        return self.prf_hz / self.n_fft

    @property
    def cpi_s(self) -> float:
        return self.n_fft / self.prf_hz

    @property
    def hop_s(self) -> float:
        """Time between STFT timesteps (50 % overlap)."""
        return self.n_fft / 2 / self.prf_hz

    def doppler_hz(self, radial_velocity_mps):
        """Doppler of a scatterer; positive when approaching (dR/dt < 0)."""
        return -2.0 * radial_velocity_mps / self.wavelength_m


@dataclass(frozen=True)
class DroneModel:
    """Rotor geometry of a multirotor drone (Table II).

    Parameters
    ----------
    name : str
        The model's name (``inspire2``, ``matrice300``, ``mini2`` in ``DRONE_MODELS``).
    n_motors : int
        Rotors.
    n_blades : int
        Blades per rotor.
    blade_length_m : float
        Blade length, hub to tip [m], in (0, 5).
    typical_motor_hz : float
        Typical rotor speed [rev/s] (the ``fixed_speeds`` variant's centre).

    Raises
    ------
    ValueError
        When a value is out of its range.

    Examples
    --------
    >>> from microdoppler.synthesis import DRONE_MODELS, DroneModel
    >>> DRONE_MODELS["inspire2"].blade_length_m
    0.19
    >>> DroneModel("quad_stand", n_motors=4, n_blades=2, blade_length_m=0.12, typical_motor_hz=160.0).n_motors
    4
    """

    name: str
    n_motors: int
    n_blades: int
    blade_length_m: float
    typical_motor_hz: float

    def __post_init__(self):
        if self.n_motors < 1:
            raise ValueError(f"n_motors={self.n_motors} must be >= 1")
        if self.n_blades < 1:
            raise ValueError(f"n_blades={self.n_blades} must be >= 1")
        if not 0 < self.blade_length_m < 5:
            raise ValueError(f"blade_length_m={self.blade_length_m} must be in (0, 5) m")
        if not self.typical_motor_hz > 0:
            raise ValueError(f"typical_motor_hz={self.typical_motor_hz} must be > 0")


#: Table II blade radii; typical speeds from Table IV's fixed-speeds row (Mini: hover
#: speed of a 250 g drone with 60 mm blades).
DRONE_MODELS = {
    "inspire2": DroneModel("inspire2", 4, 2, 0.19, 80.0),
    "matrice300": DroneModel("matrice300", 4, 2, 0.22, 60.0),
    "mini2": DroneModel("mini2", 4, 2, 0.06, 180.0),
}
