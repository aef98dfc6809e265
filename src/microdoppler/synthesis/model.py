"""Drone micro-Doppler synthesis: thin-wire blades (eq. 1) and the body/blade/alpha
model (eq. 2).

Eq. (1): each blade of length L is a thin wire rotating about its motor hub,

    g(phi) = L exp(-j k L/2 cos phi) sinc(k L/2 cos phi),   k = 4 pi / lambda,

with sinc(x) = sin(x)/x, summed over the B blades of a rotor at phases
phi + 2 pi b / B, each times its own scattering amplitude a_b (``BladeModel.blade_amplitudes``,
default 1: eq. (1) itself; unequal blades add lines at every multiple of the rotation
rate). The blade phase is the *time integral* of the rotation rate
(phi(t) = phi0 + 2 pi integral f(t) dt), not Omega_t * t, which would create false
chirps once the speed varies.

Fast kernel: the blade sum G(phi) = sum_b g(phi + 2 pi b / B) depends on the rotor
angle only, so it is tabulated once over one revolution (``table_size`` points,
nearest lookup; phase error < pi/table_size rad). A pulse then costs one table
lookup per motor. Rotor angles are uint32 fixed-point fractions of a revolution
accumulated from per-pulse increments rev_s / prf (wrap-around modulo one turn is
free; the table index is the top 16 bits). The body carrier exp(-j 4 pi R / lambda)
is looked up the same way, its phase 2R/lambda evaluated on a global grid every
``CARRIER_STEP`` pulses and interpolated linearly in between.

Eq. (2): x = S_body b(t) + S_blade [h * m](t) b(t) (+ background), where b(t) is the
body carrier, m(t) = sum over motors of G(phi_m(t)) is the blade signal relative to
the body, and h is the alpha envelope. The paper writes the envelope as
exp(-alpha(|v| - v_body)) "Fourier transformed and summed element-wise"; an
attenuation of sidebands is a *multiplication in frequency*, so we implement it as a
linear filter with frequency response H(f) = exp(-alpha |f|) applied to m(t), i.e.
in the frame that moves with the body, so the envelope is centred on the body
Doppler as it changes. Larger alpha [s] leaves fewer sideband pairs (see NOTES.md).

Two ways to apply the envelope (``Envelope(method=...)``):

* "harmonic" (default when no ``envelope_gain`` is given): G is periodic in
  the rotor angle, G(phi) = sum_n c_n exp(j n phi), and only harmonics n = m B are
  non-zero (B equal blades repeat every 1/B turn). At a constant motor speed f_m,
  harmonic n sits at Doppler n f_m relative to the body, so H is exactly the
  per-harmonic gain exp(-alpha |n f_m|). We tabulate
  G_alpha(phi; f) = sum_n c_n exp(-alpha |n f|) exp(j n phi) over one period 1/B
  turn (``ENVELOPE_TABLE_SIZE`` = 2048 angles, nearest lookup of the B-fold angle
  B phi) on a global grid of speeds (``ENVELOPE_SPEED_STEP`` = 0.25 rev/s; each
  pulse uses the grid speed nearest its motor's speed, read every
  ``ENVELOPE_SPEED_STRIDE`` = 16 pulses). Unequal blades repeat only once a turn:
  their tables span the whole revolution (every n, 2048 angles per 1/B turn as
  before). A pulse costs one lookup per motor and no FFT, like alpha = 0. This is a *quasi-static* envelope: it uses each motor's current
  speed, where the linear filter would mix the speeds within its impulse response (a
  Lorentzian of half-width alpha / (2 pi) s, ~1 ms at alpha = 5.5e-3 s). Measured
  against the FFT filter (record interior, one FFT over the whole record, 4 motors,
  Inspire blade, L-band, PRF 7300 Hz; max |difference| / max |x|, rms ratio):
  constant speeds 1.1e-3 / 6e-4 at alpha = 5.5e-3 s (2.7e-3 / 1.8e-3 at 1e-3 s,
  where more harmonics survive the envelope and the 2048-angle table dominates);
  speeds drifting +-5 rev/s over 7-13 s (a flying quadcopter) the same; fast sweeps
  (+-20 rev/s over 1-2 s) 1.7e-3 / 6e-4; the PX4 sample motor log
  (data/motor-logs, 24-49 rev/s, sub-CPI resampled) 2.0e-3 / 1.3e-3, i.e. errors
  50-60 dB below the signal. Differences
  from the FFT filter by design: the gain is applied at the true Doppler n f_m (the
  FFT filter sees it aliased into +-prf/2; irrelevant once exp(-alpha prf/2) is
  negligible), there are no edge effects (the FFT filter takes the blade signal as
  zero outside the record), and the result does not depend on chunking at all.
* "fft": the linear filter H(f), applied per chunk by FFT with a margin of
  ``margin_pulses`` on each side (overlap-save), so memory does not grow with flight
  length; outside the record the blade signal is taken as zero (the first and last
  chunks are zero-padded by the margin), so the result does not depend on the chunk
  size beyond the truncation of the envelope's Lorentzian impulse response at
  ``margin_pulses`` (relative error ~ alpha prf / (pi^2 margin)). Used whenever an
  ``envelope_gain(f)`` is given (model extensions: asymmetric sidebands), and
  on request.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
import scipy.fft as sfft
from scipy.interpolate import CubicSpline

from .radar import DRONE_MODELS, Radar

TABLE_SIZE = 1 << 16


@dataclass(frozen=True)
class BladeModel:
    """Rotor of ``n_blades`` thin-wire blades of ``blade_length_m`` at ``wavelength_m`` (eq. 1).

    Parameters
    ----------
    n_blades : int
        Blades per rotor, at angles 2 pi b / n_blades.
    blade_length_m : float
        Blade length, hub to tip [m].
    wavelength_m : float
        Radar wavelength [m].
    table_size : int
        Angles of the rotor table over one revolution (a power of two).
    blade_amplitudes : array-like, float [n_blades] or [n_motors, n_blades], optional
        Each blade's scattering amplitude relative to eq. (1)'s thin wire (>= 0):
        G(phi) = sum_b a_b g(phi + 2 pi b / B). Default (None): every blade 1, eq. (1)
        itself. One row applies to every motor; a row per motor gives each rotor its
        own. Unequal blades (chipped, bent, repaired, tagged) put lines at every
        multiple of the rotation rate, not only at multiples of the blade-passing rate:
        for two blades harmonic n of the rotor is c_n (a_0 + (-1)^n a_1), c_n the single
        blade's (the second blade sits at phi + pi), so relative to the blade's own
        harmonics the odd lines stand ((a_0 - a_1) / (a_0 + a_1))^2 below the even ones.
    scattering : {"thin_wire", "dielectric"}
        Blade echo model (:func:`blade_scattering_gain`): eq. (1)'s thin wire (default,
        the paper's model) or thin plastic blades, whose echo falls as (L / lambda)^2
        below eq. (1) for small blades (normalised to the 0.19 m blade at 1.35 GHz);
        :attr:`gain` multiplies S_blade.
    """

    n_blades: int
    blade_length_m: float
    wavelength_m: float
    table_size: int = TABLE_SIZE
    blade_amplitudes: tuple | None = None
    scattering: str = "thin_wire"

    def __post_init__(self):
        if self.n_blades < 1:
            raise ValueError(f"n_blades={self.n_blades} must be >= 1")
        if not self.blade_length_m > 0:
            raise ValueError(f"blade_length_m={self.blade_length_m} must be > 0")
        if not self.wavelength_m > 0:
            raise ValueError(f"wavelength_m={self.wavelength_m} must be > 0")
        if self.table_size < 1 or self.table_size & (self.table_size - 1):
            raise ValueError(f"table_size={self.table_size} must be a power of two")
        if self.scattering not in BLADE_SCATTERING:
            raise ValueError(f"scattering={self.scattering!r} must be one of {BLADE_SCATTERING}")
        if self.blade_amplitudes is not None:
            a = np.asarray(self.blade_amplitudes, np.float64)
            if a.ndim not in (1, 2) or a.shape[-1] != self.n_blades or a.size == 0:
                raise ValueError(
                    f"blade_amplitudes has shape {a.shape}, expected (n_blades={self.n_blades},) "
                    f"or (n_motors, {self.n_blades})"
                )
            if not np.all(np.isfinite(a)) or np.any(a < 0):
                raise ValueError(f"blade_amplitudes={a.tolist()} must be finite and >= 0")
            amps = tuple(map(float, a)) if a.ndim == 1 else tuple(tuple(map(float, r)) for r in a)
            object.__setattr__(self, "blade_amplitudes", amps)

    @property
    def gain(self) -> float:
        """Blade echo amplitude relative to eq. (1) (:func:`blade_scattering_gain`)."""
        return blade_scattering_gain(self.blade_length_m, self.wavelength_m, self.scattering)

    @property
    def equal_blades(self) -> bool:
        """True when every rotor's blades scatter alike (harmonics only at multiples of
        ``n_blades``); rotors may still differ from each other."""
        if self.blade_amplitudes is None:
            return True
        rows = np.atleast_2d(np.asarray(self.blade_amplitudes, np.float64))
        return bool(np.all(rows == rows[:, :1]))

    def check_motors(self, n_motors: int) -> None:
        """Raise ValueError unless the amplitudes fit ``n_motors`` rotors."""
        a = self.blade_amplitudes
        if a is not None and isinstance(a[0], tuple) and len(a) != n_motors:
            raise ValueError(f"blade_amplitudes has {len(a)} rows, expected 1 or one per motor ({n_motors})")

    def amplitudes(self, motor: int = 0) -> tuple | None:
        """Blade amplitudes of rotor ``motor`` (float [n_blades]); None for eq. (1)'s
        equal unit blades."""
        a = self.blade_amplitudes
        if a is None:
            return None
        row = a[motor] if isinstance(a[0], tuple) else a
        return None if all(v == 1.0 for v in row) else row

    def blade(self, phi: np.ndarray) -> np.ndarray:
        """Eq. (1) for one blade at rotor angle ``phi`` [rad], complex128."""
        k = 4 * np.pi / self.wavelength_m
        a = k * self.blade_length_m / 2 * np.cos(phi)
        return self.blade_length_m * np.exp(-1j * a) * np.sinc(a / np.pi)

    def rotor(self, phi: np.ndarray, motor: int = 0) -> np.ndarray:
        """Sum over rotor ``motor``'s blades (each times its amplitude) at rotor angle
        ``phi`` [rad], complex128."""
        phi = np.asarray(phi, dtype=np.float64)
        B = self.n_blades
        amps = self.amplitudes(motor)
        if amps is None:
            return sum(self.blade(phi + 2 * np.pi * b / B) for b in range(B))
        return sum(a * self.blade(phi + 2 * np.pi * b / B) for b, a in enumerate(amps))

    def table(self, motor: int = 0) -> np.ndarray:
        """G of rotor ``motor`` over one revolution: complex64 [table_size] at angles
        2 pi i / table_size."""
        return _rotor_table(
            self.n_blades, self.blade_length_m, self.wavelength_m, self.table_size, self.amplitudes(motor)
        )


#: blade scattering models (:func:`blade_scattering_gain`)
BLADE_SCATTERING = ("thin_wire", "dielectric")
#: reference of the dielectric model: the paper's Inspire blade (Fig. 2, Table II,
#: 0.19 m) at its L-band carrier (1.35 GHz), where both models give the same amplitude
DIELECTRIC_REF_LENGTH_M = DRONE_MODELS["inspire2"].blade_length_m
DIELECTRIC_REF_WAVELENGTH_M = Radar().wavelength_m


def blade_scattering_gain(blade_length_m: float, wavelength_m: float, model: str = "thin_wire") -> float:
    """Blade echo amplitude relative to eq. (1)'s thin wire of the same length.

    ``thin_wire`` (eq. 1, the paper's model): 1. A perfectly conducting thin wire
    scatters with a current per unit length that does not depend on its thickness
    (only logarithmically on L / lambda), so the broadside echo grows as L and the
    first HERM harmonic, c_B ~ (1 - J0(k L)) / k with k = 4 pi / lambda, hardly
    depends on L once k L > 3: the 0.06 m Mini blade's first sideband pair sits only
    ~2 dB below the 0.19 m Inspire blade's.

    ``dielectric``: a plastic blade is a thin low-contrast dielectric rod (chord and
    thickness << lambda). In the Rayleigh-Gans approximation each length element ds
    is a small dipole of polarisability ~ (eps_r - 1) A ds (A: cross-section) that
    radiates ~ k^2 times it, and summing the elements along the blade gives eq. (1)'s
    pattern L sinc(.) exp(.) times k^2 (eps_r - 1) A instead of a size-independent
    factor. Propellers of one family scale about geometrically (chord and thickness
    proportional to L), so A ~ L^2 and the echo gains a factor ~ (L / lambda)^2:
    small blades at L-band scatter much less than eq. (1) says, which is why the
    paper's Mini shows no micro-Doppler. Normalised to 1 for the
    ``DIELECTRIC_REF_LENGTH_M`` = 0.19 m blade at ``DIELECTRIC_REF_WAVELENGTH_M``
    (1.35 GHz), so S_blade keeps its meaning for the Inspire:

        gain = (L / 0.19 m)^2 (lambda_ref / lambda)^2

    (Mini, 0.06 m: -20.0 dB; Matrice, 0.22 m: +2.5 dB, at 1.35 GHz). Valid while
    the blade cross-section is thin compared with lambda / sqrt(eps_r); resonance of
    blades about as long as lambda / 2 is in neither model.
    """
    if model not in BLADE_SCATTERING:
        raise ValueError(f"blade_scattering={model!r} must be one of {BLADE_SCATTERING}")
    if not blade_length_m > 0 or not wavelength_m > 0:
        raise ValueError(f"blade_length_m={blade_length_m} and wavelength_m={wavelength_m} must be > 0")
    if model == "thin_wire":
        return 1.0
    return float((blade_length_m / DIELECTRIC_REF_LENGTH_M) ** 2 * (DIELECTRIC_REF_WAVELENGTH_M / wavelength_m) ** 2)


_TABLES: dict = {}


def _rotor_table(n_blades, blade_length_m, wavelength_m, size, amplitudes=None):
    key = (n_blades, blade_length_m, wavelength_m, size) + ((amplitudes,) if amplitudes is not None else ())
    if key not in _TABLES:
        bm = BladeModel(n_blades, blade_length_m, wavelength_m, size, blade_amplitudes=amplitudes)
        phi = 2 * np.pi * np.arange(size) / size
        _TABLES[key] = bm.rotor(phi).astype(np.complex64)
    return _TABLES[key]


def _carrier_table(size=TABLE_SIZE):
    key = ("carrier", size)
    if key not in _TABLES:
        _TABLES[key] = np.exp(-2j * np.pi * np.arange(size) / size).astype(np.complex64)
    return _TABLES[key]


@dataclass
class Track:
    """Target range over time: a cubic spline through (time_s, range_m).

    Parameters
    ----------
    time_s : array-like, float64 [n_track]
        Strictly increasing times [s], at least two.
    range_m : array-like, float64 [n_track]
        Range at those times [m], > 0.

    Raises
    ------
    ValueError
        When the times are not strictly increasing or a range is not > 0.

    See Also
    --------
    synthesize

    Examples
    --------
    >>> from microdoppler.synthesis import Track
    >>> track = Track.constant_velocity(100.0, -2.0, 3.0)
    >>> round(float(track.range_at(1.5)), 6), round(float(track.radial_velocity_at(1.5)), 6)
    (97.0, -2.0)
    """

    time_s: np.ndarray
    range_m: np.ndarray
    _spline: CubicSpline = field(init=False, repr=False)

    def __post_init__(self):
        self.time_s = np.asarray(self.time_s, np.float64)
        self.range_m = np.asarray(self.range_m, np.float64)
        if self.time_s.ndim != 1 or len(self.time_s) < 2 or np.any(np.diff(self.time_s) <= 0):
            raise ValueError("track time_s must be 1-D, strictly increasing, with >= 2 rows")
        if self.range_m.shape != self.time_s.shape or np.any(self.range_m <= 0):
            raise ValueError("track range_m must match time_s and be > 0")
        self._spline = CubicSpline(self.time_s, self.range_m, bc_type="natural", extrapolate=True)

    @classmethod
    def constant_velocity(cls, range_m: float, radial_velocity_mps: float, duration_s: float) -> "Track":
        t = np.linspace(0.0, max(duration_s, 1e-3), 16)
        return cls(t, range_m + radial_velocity_mps * t)

    @classmethod
    def from_tracker(cls, time_s, range_m, radial_velocity_mps, smooth_s: float = 10.0) -> "Track":
        """The target's range from a tracker's range and radial-velocity outputs.

        A tracker's range is good over seconds but noisy from sample to sample
        (range cells of metres, against wavelengths of 0.1-0.3 m): a spline through it
        would give the twin's body a Doppler that jumps by hundreds of Hz. Its radial
        velocity is smooth but integrates to a drifting range. A complementary filter
        takes each where it is good: the integrated radial velocity (trapezoid), plus
        the range's offset from it averaged over ``smooth_s`` [s] (a triangular window
        of twice that span).
        For a track whose range and velocity agree (the emulator's) it returns the
        range itself to within the averaged disagreement.

        Parameters
        ----------
        time_s, range_m, radial_velocity_mps : ndarray, float64 [n_track]
            The flight's ``track/*`` (strictly increasing time, range > 0 [m],
            velocity positive receding [m/s]).
        smooth_s : float
            Window of the range's low-frequency part [s].
        """
        t = np.asarray(time_s, np.float64)
        r = np.asarray(range_m, np.float64)
        v = np.asarray(radial_velocity_mps, np.float64)
        if not (t.shape == r.shape == v.shape) or t.ndim != 1 or len(t) < 2:
            raise ValueError("track time_s, range_m and radial_velocity_mps must be 1-D of one length >= 2")
        integ = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
        off = r - integ
        dt = float(np.median(np.diff(t)))
        w = int(max(1, round(smooth_s / dt))) | 1
        k = np.convolve(np.ones(w), np.ones(w))  # triangular: a smooth offset, no steps
        if len(k) >= len(t):
            smooth_off = np.full(len(t), float(np.mean(off)))
        else:
            smooth_off = np.convolve(off, k, mode="same") / np.convolve(np.ones(len(t)), k, mode="same")
        fused = integ + smooth_off
        return cls(t, np.maximum(fused, 1.0))

    def range_at(self, t_s: np.ndarray) -> np.ndarray:
        return self._spline(t_s)

    def radial_velocity_at(self, t_s: np.ndarray) -> np.ndarray:
        return self._spline(t_s, 1)


@dataclass(frozen=True)
class Scaling:
    """Eq. (2) parameters: body and blade amplitude scales and the alpha envelope [s].

    Parameters
    ----------
    s_body, s_blade : float
        Amplitude of the body and of the blade echo (>= 0, linear, relative).
    alpha_s : float
        Time constant of the envelope smoothing the blade flashes [s] (>= 0; 0: none).

    Examples
    --------
    >>> from microdoppler.synthesis import Scaling
    >>> Scaling(s_body=1.0, s_blade=20.0, alpha_s=0.001)
    Scaling(s_body=1.0, s_blade=20.0, alpha_s=0.001)
    """

    s_body: float = 1.0
    s_blade: float = 1.0
    alpha_s: float = 0.0

    def __post_init__(self):
        if self.s_body < 0 or self.s_blade < 0:
            raise ValueError(f"s_body={self.s_body} and s_blade={self.s_blade} must be >= 0")
        if self.alpha_s < 0:
            raise ValueError(f"alpha_s={self.alpha_s} must be >= 0")


def rotor_cycles(rev_s_chunk: np.ndarray, prf_hz: float, start_cycles: np.ndarray) -> np.ndarray:
    """Rotor angle in revolutions at each pulse: start + cumulative integral of the rate.

    ``rev_s_chunk`` [n, M] -> cycles [n, M] float64; the cycle count *after* the chunk
    is ``start + sum(rate) / prf``. The angle at pulse i is the integral up to pulse i.
    """
    c = np.cumsum(rev_s_chunk, axis=0, dtype=np.float64)
    c /= prf_hz
    c += start_cycles
    c -= rev_s_chunk / prf_hz  # integral *before* pulse i, so pulse 0 sits at start
    return c


def lookup(table: np.ndarray, cycles: np.ndarray) -> np.ndarray:
    """Nearest table value at ``cycles`` revolutions (cycles >= 0)."""
    n = table.shape[0]
    idx = (cycles * n + 0.5).astype(np.int64)
    idx &= n - 1
    return table[idx]


def envelope_response(n: int, prf_hz: float, alpha_s: float) -> np.ndarray:
    """H(f) = exp(-alpha |f|) on the FFT grid of length ``n`` (complex64)."""
    f = sfft.fftfreq(n, 1.0 / prf_hz)
    return np.exp(-alpha_s * np.abs(f)).astype(np.complex64)


#: speed grid of the harmonic envelope tables [rev/s]: a motor at speed f uses the
#: table of the nearest grid speed k step (|f - k step| <= step / 2), so the gain of
#: harmonic n is off by at most a factor exp(alpha |n| step / 2): 0.14 % (0.012 dB)
#: for the first pair of a 2-blade rotor at alpha = 5.5e-3 s, relative to a line
#: already attenuated by exp(-alpha |n| f). A nearest row costs one lookup per motor
#: and pulse (linear interpolation in speed would cost two and a multiply). Finer
#: steps cost speed: a motor then leaves its row before the row's cache lines are
#: reused (0.125 rev/s with 4096 angles: 1.6x slower than 0.25 with 2048)
ENVELOPE_SPEED_STEP = 0.25
#: angles per harmonic envelope table over one table period (1/B revolution), nearest
#: lookup of the B-fold angle: 2048 B per revolution (B = 2: 4096). Against the FFT
#: filter (4 motors, Inspire blade): ~7e-4 rms, ~1.3e-3 max of max|x| at alpha =
#: 5.5e-3 s; ~1.8e-3 rms, 2.5e-3 max at alpha = 1e-3 s, where more harmonics survive
#: (-55 dB: far below any line a spectrogram shows); 16 KiB rows stay in the L2 cache
ENVELOPE_TABLE_SIZE = 1 << 11
#: most speed bins kept at once (2048 x 8 B each: 2048 bins = 32 MiB, a 512 rev/s
#: span at 0.25 rev/s); beyond this the cache is rebuilt for the current chunk's speeds
ENVELOPE_MAX_BINS = 2048
#: the speed of each motor is read every this many pulses (on a global grid) and held
#: in between: 16 pulses = 2.2 ms at 7.3 kHz, over which a motor's speed changes by
#: ~0.01 rev/s at 5 rev/s^2
ENVELOPE_SPEED_STRIDE = 16
ENVELOPE_METHODS = ("auto", "harmonic", "fft")


class _HarmonicTables:
    """Rotor tables with the alpha envelope applied per harmonic, on a global speed grid.

    A rotor of B equal blades repeats every 1/B revolution, so only harmonics n = m B
    of G are non-zero and G(phi) = Ghat(B phi) with Ghat(theta) = sum_m c_{mB}
    exp(j m theta). Row ``k - k0`` of :attr:`table` is Ghat_alpha(theta; k step) =
    sum_m c_{mB} exp(-alpha |m B| |k step|) exp(j m theta) at ``size`` angles theta
    over one period (1/B revolution: B times the angular resolution of a full-turn
    table of the same size); c_n are the harmonics of the 2**16-point rotor table.
    Rows depend only on k, so the result does not depend on chunking; the cache only
    grows to cover the speeds seen.
    """

    def __init__(
        self,
        base_table: np.ndarray,
        alpha_s: float,
        n_blades: int,
        size: int = ENVELOPE_TABLE_SIZE,
        step: float = ENVELOPE_SPEED_STEP,
    ):
        nb = base_table.shape[0]
        if size * n_blades > nb:
            raise ValueError(f"size={size} x n_blades={n_blades} must be <= the rotor table's {nb}")
        c = np.fft.fft(base_table.astype(np.complex128)) / nb
        m = np.arange(-(size // 2) + 1, size // 2)  # harmonic m of Ghat is n = m B of G
        m = m[np.abs(m * n_blades) < nb // 2]  # (beyond size/2 they would alias in the table)
        self.coef = np.zeros(size, np.complex128)
        self.coef[m % size] = c[(m * n_blades) % nb]
        self.abs_n = n_blades * np.abs(np.fft.fftfreq(size, 1.0 / size))  # |n| = B |m|
        self.alpha_s = float(alpha_s)
        self.size = size
        self.bits = size.bit_length() - 1
        self.step = float(step)
        self.k0, self.k1 = 0, -1  # bins held: k0..k1
        self.table = np.empty((0, size), np.complex64)

    def rows(self, ks: np.ndarray) -> np.ndarray:
        """G_alpha at the speeds ks * step: complex64 [len(ks), size]."""
        g = np.exp(-self.alpha_s * np.abs(ks * self.step)[:, None] * self.abs_n[None, :])
        return (np.fft.ifft(self.coef[None, :] * g, axis=1) * self.size).astype(np.complex64)

    def cover(self, k_lo: int, k_hi: int) -> None:
        """Make :attr:`table` hold rows k_lo..k_hi (row j is bin k0 + j; the flat index
        of angle i in bin k is (k - k0) * size + i)."""
        if k_lo >= self.k0 and k_hi <= self.k1:
            return
        if self.k1 >= self.k0 and max(k_hi, self.k1) - min(k_lo, self.k0) + 1 <= ENVELOPE_MAX_BINS:
            lo, hi = min(k_lo, self.k0), max(k_hi, self.k1)
        else:
            lo, hi = k_lo, k_hi
        new = np.empty((hi - lo + 1, self.size), np.complex64)
        ks = np.arange(lo, hi + 1)
        have = (ks >= self.k0) & (ks <= self.k1)
        if have.any():
            o0, o1 = max(lo, self.k0), min(hi, self.k1)
            new[o0 - lo : o1 - lo + 1] = self.table[o0 - self.k0 : o1 - self.k0 + 1]
        for j0 in range(0, len(ks), 64):  # bounded temporaries
            sel = np.flatnonzero(~have[j0 : j0 + 64]) + j0
            if len(sel):
                new[sel] = self.rows(ks[sel])
        self.k0, self.k1, self.table = lo, hi, new


Hook = Callable[[int, int, np.ndarray, np.ndarray], None]


@dataclass(frozen=True)
class Envelope:
    """How eq. (2)'s alpha envelope (``Scaling.alpha_s``) is applied (module docstring).

    Parameters
    ----------
    method : {"auto", "harmonic", "fft"}
        "harmonic" scales rotor harmonic n by exp(-alpha |n f_m|) at each motor's
        current speed (tables per ``ENVELOPE_SPEED_STEP`` rev/s; quasi-static, no FFT);
        "fft" filters m(t) with H(f) per chunk (overlap-save). "auto" (default): "fft"
        where the extensions give an ``envelope_gain``, else "harmonic".
    margin_pulses : int
        Filter margin [pulses] on each side of a chunk (overlap-save; "fft" only): the
        envelope's Lorentzian impulse response is truncated there (relative error
        ~ alpha prf / (pi^2 margin)).
    """

    method: str = "auto"
    margin_pulses: int = 4096

    def __post_init__(self):
        if self.method not in ENVELOPE_METHODS:
            raise ValueError(f"method={self.method!r} must be one of {ENVELOPE_METHODS}")
        if self.margin_pulses < 0:
            raise ValueError(f"margin_pulses={self.margin_pulses} must be >= 0")


@dataclass(frozen=True)
class ModelExtensions:
    """Model extensions acting inside the synthesis (what
    :meth:`microdoppler.causes.extensions.ExtensionSet.model_extensions` gives).

    Parameters
    ----------
    envelope_gain : callable, optional
        ``envelope_gain(f_hz) -> gain`` multiplies H(f) (f relative to the body Doppler,
        on the FFT grid), e.g. an asymmetric gain for upper vs lower sidebands; with
        it the envelope is applied by the FFT filter.
    blade_hook, body_hook : callable, optional
        ``hook(i0, i1, t_s, x)`` modifies the blade signal (after the envelope and
        S_blade) or the body amplitude of pulses [i0, i1) in place (``t_s``: float64
        [i1 - i0] pulse times [s]).
    """

    envelope_gain: Callable[[np.ndarray], np.ndarray] | None = None
    blade_hook: Hook | None = None
    body_hook: Hook | None = None


@dataclass(frozen=True)
class SynthesisConfig:
    """Everything :func:`~microdoppler.synthesis.synthesize` needs besides the flight (track, rotor speeds).

    Parameters
    ----------
    prf_hz : float
        Pulse repetition frequency [Hz]; pulse i is at t = i / prf_hz.
    blades : BladeModel
        Rotor geometry, wavelength, per-blade amplitudes and scattering model.
    scaling : Scaling
        S_body, S_blade and alpha (eq. 2).
    envelope : Envelope
        How the alpha envelope is applied.
    extensions : ModelExtensions
        Envelope gain and blade/body hooks of model extensions (default: none).
    chunk_pulses : int, optional
        Output pulses per chunk (default 2**17; with the FFT filter 2**17 minus the
        two filter margins, so the envelope FFT has a power-of-two length). Memory
        beyond the output is O(chunk); the result does not depend on it (FFT filter:
        beyond the truncation at ``envelope.margin_pulses``).

    Raises
    ------
    ValueError
        When ``prf_hz`` is not > 0 or the settings contradict each other.

    See Also
    --------
    synthesize, Radar

    Examples
    --------
    >>> from microdoppler.synthesis import Radar, SynthesisConfig
    >>> radar = Radar(prf_hz=5000.0, carrier_hz=3.3e9)
    >>> cfg = SynthesisConfig.of(prf_hz=radar.prf_hz, wavelength_m=radar.wavelength_m, n_blades=2,
    ...                          blade_length_m=0.12)
    >>> cfg.blades.n_blades, round(cfg.wavelength_m, 4)
    (2, 0.0908)
    """

    prf_hz: float
    blades: BladeModel
    scaling: Scaling = Scaling()
    envelope: Envelope = Envelope()
    extensions: ModelExtensions = ModelExtensions()
    chunk_pulses: int | None = None

    def __post_init__(self):
        if not self.prf_hz > 0:
            raise ValueError(f"prf_hz={self.prf_hz} must be > 0")
        if self.chunk_pulses is not None and self.chunk_pulses < 1:
            raise ValueError(f"chunk_pulses={self.chunk_pulses} must be >= 1")
        if self.envelope.method == "harmonic" and self.extensions.envelope_gain is not None:
            raise ValueError("Envelope(method='harmonic') does not take an envelope_gain; use 'fft' or 'auto'")

    @classmethod
    def of(
        cls,
        *,
        prf_hz: float,
        wavelength_m: float,
        n_blades: int,
        blade_length_m: float,
        scaling: Scaling = Scaling(),
        blade_amplitudes=None,
        scattering: str = "thin_wire",
        envelope: Envelope = Envelope(),
        extensions: ModelExtensions = ModelExtensions(),
        chunk_pulses: int | None = None,
    ) -> "SynthesisConfig":
        """The configuration from flat parameters (the ``BladeModel`` built here)."""
        blades = BladeModel(
            int(n_blades), blade_length_m, wavelength_m, blade_amplitudes=blade_amplitudes, scattering=scattering
        )
        return cls(prf_hz, blades, scaling, envelope, extensions, chunk_pulses)

    @property
    def wavelength_m(self) -> float:
        return self.blades.wavelength_m

    @property
    def harmonic(self) -> bool:
        """True when the alpha envelope is applied by the harmonic tables."""
        return (
            self.scaling.alpha_s > 0
            and self.scaling.s_blade > 0
            and self.extensions.envelope_gain is None
            and self.envelope.method in ("auto", "harmonic")
        )

    @property
    def fft_filter(self) -> bool:
        """True when the envelope is applied by the FFT filter."""
        return (
            (self.scaling.alpha_s > 0 or self.extensions.envelope_gain is not None)
            and self.scaling.s_blade > 0
            and not self.harmonic
        )


#: fixed-point phase: one revolution (or one carrier cycle) = 2**32, so uint32
#: arithmetic wraps modulo one revolution for free
PHASE_ONE = 1 << 32
#: pulses per lookup sub-block (tuned on one core: buffers stay in L2/L3)
SUB_BLOCK = 1 << 16
#: the track range is evaluated every CARRIER_STEP pulses and the carrier phase
#: interpolated linearly in between (range error <= a dt^2 / 8 for acceleration a:
#: 10 m/s^2 and 16 pulses at 7.3 kHz give 6e-6 m, 3.4e-4 rad at L-band)
CARRIER_STEP = 16


def _fixed_phase(cycles) -> np.ndarray:
    """Revolutions -> uint32 fixed-point phase (fraction of a revolution * 2**32)."""
    c = np.asarray(cycles, np.float64)
    frac = c - np.floor(c)
    return (np.floor(frac * PHASE_ONE).astype(np.uint64) & np.uint64(PHASE_ONE - 1)).astype(np.uint32)


def _increments(
    rates: np.ndarray, scale: float, f64: np.ndarray, out: np.ndarray, in_range: bool = False
) -> np.ndarray:
    """Per-pulse phase increments ``rates * scale`` as uint32 modulo 2**32
    (``in_range``: the caller has checked 0 <= rates * scale < 2**32)."""
    n = rates.shape[0]
    if in_range:  # one fused pass: the product is cast (truncated) straight to uint32
        return np.multiply(rates, scale, out=out[:n], casting="unsafe")
    f = np.multiply(rates, scale, out=f64[:n])
    if n and (f.max() >= PHASE_ONE or f.min() < 0):  # |rate| >= prf or reverse rotation
        np.copyto(out[:n], np.mod(np.floor(f), PHASE_ONE).astype(np.int64), casting="unsafe")
    else:
        np.copyto(out[:n], f, casting="unsafe")  # truncation: bias 2**-33 rev per pulse
    return out[:n]


def _add_row_offsets(idx: np.ndarray, start: int, q: int, koff: np.ndarray) -> None:
    """idx[i] += koff[(start + i) // q] in place, without a per-pulse offset array:
    the pulses of each stride of q share one speed row (head and tail strides may be
    partial)."""
    n = idx.shape[0]
    j = start // q
    head = min(n, (-start) % q)
    if head:
        idx[:head] += koff[j]
        j += 1
    full = (n - head) // q
    if full:
        idx[head : head + full * q].reshape(full, q)[...] += koff[j : j + full, None]
    if head + full * q < n:
        idx[head + full * q :] += koff[j + full]


def _carrier_phase(
    track: "Track", a: int, b: int, prf_hz: float, wavelength_m: float, half: int, out: np.ndarray
) -> np.ndarray:
    """uint32 fixed-point phase of 2 R(t) / lambda [cycles] at pulses [a, b) (+ ``half``
    for nearest-neighbour rounding in the table lookup)."""
    n = b - a
    step = CARRIER_STEP
    g0 = (a // step) * step  # nodes on a global grid: the result does not depend on chunking
    n_seg = -(-(b - g0) // step)
    t_nodes = (g0 + np.arange(n_seg + 1, dtype=np.float64) * step) / prf_hz
    cyc = 2.0 * track.range_at(t_nodes) / wavelength_m
    base = _fixed_phase(cyc[:-1]) + np.uint32(half)
    slope = np.round(np.diff(cyc) / step * PHASE_ONE).astype(np.int64).astype(np.uint32)
    ph = out[: n_seg * step].reshape(n_seg, step)
    np.multiply(slope[:, None], np.arange(step, dtype=np.uint32)[None, :], out=ph)
    ph += base[:, None]
    return out[a - g0 : a - g0 + n]


def synthesize(
    config: SynthesisConfig,
    track: Track,
    rev_s,
    *,
    n_pulses: int | None = None,
    initial_cycles: Sequence[float] | None = None,
    seed: int = 0,
    out: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> np.ndarray:
    """Synthesise the drone echo of eq. (2) without background or noise.

    Parameters
    ----------
    config : SynthesisConfig
        Radar PRF, blade model, scaling, envelope and extensions.
    track : Track
        Body range over time; pulse i is at t = i / prf_hz.
    rev_s : array-like, float [n_pulses, n_motors]
        Rotation rate of each motor at each pulse [rev/s]; sliced per chunk, so a
        Zarr array or memory map works and is never loaded whole.
    n_pulses : int, optional
        Pulses to synthesise (default ``rev_s.shape[0]``).
    initial_cycles : sequence of float, optional
        Initial rotor angles [rev]; default drawn from ``seed``.
    seed : int
        Seed of the initial rotor angles.
    out : ndarray, complex64 [n_pulses], optional
        Output buffer.
    progress : callable, optional
        ``progress(done, total)`` after each chunk [pulses].

    Returns
    -------
    iq : ndarray, complex64 [n_pulses]
        The echo, body amplitude ``S_body`` (no noise; see :func:`add_noise`).

    Raises
    ------
    ValueError
        When ``n_pulses`` exceeds the rows of ``rev_s`` or ``initial_cycles`` does not
        have one angle per motor.

    See Also
    --------
    SynthesisConfig, Track, add_noise, microdoppler.rotors.resample

    Notes
    -----
    Rotor angles and the carrier phase are carried as uint32 fixed-point fractions
    of a revolution/cycle (2**-32 rev resolution; wrap-around is modulo one turn for
    free); each pulse's increment ``rev_s / prf_hz`` is truncated to 2**-32 rev, a
    frequency error below 1e-5 Hz. The table index is the top ``log2(TABLE_SIZE)``
    bits (nearest neighbour). Memory beyond ``out`` is O(chunk).

    Examples
    --------
    A quadcopter on a stand (body at 0 Hz, 25 m) at 160 rev/s, seen for 1 s by a
    3.3 GHz radar at 5 kHz:

    >>> import numpy as np
    >>> from microdoppler.synthesis import Radar, SynthesisConfig, Track, synthesize
    >>> radar = Radar(prf_hz=5000.0, carrier_hz=3.3e9)
    >>> cfg = SynthesisConfig.of(prf_hz=radar.prf_hz, wavelength_m=radar.wavelength_m, n_blades=2,
    ...                          blade_length_m=0.12)
    >>> rev_s = np.full((5000, 4), 160.0, np.float32)
    >>> iq = synthesize(cfg, Track.constant_velocity(25.0, 0.0, 1.0), rev_s, seed=0)
    >>> iq.shape, iq.dtype
    ((5000,), dtype('complex64'))
    """
    n_total = rev_s.shape[0] if n_pulses is None else int(n_pulses)
    if n_total > rev_s.shape[0]:
        raise ValueError(f"n_pulses={n_total} exceeds the {rev_s.shape[0]} rows of rev_s")
    start = _initial_cycles(initial_cycles, seed, rev_s.shape[1])
    if out is None:
        out = np.empty(n_total, np.complex64)
    k = _Kernel(config, n_total, start)
    for i0 in range(0, n_total, k.chunk):
        i1 = min(i0 + k.chunk, n_total)
        a, b = max(0, i0 - k.margin), min(n_total, i1 + k.margin)
        m = k.envelope_filter(k.blade_signal(rev_s, a, i0, i1, b), a, b)
        k.emit(m[i0 - a : i1 - a], i0, i1, track, out)
        if progress is not None:
            progress(i1, n_total)
    return out


def _initial_cycles(initial_cycles, seed: int, n_motors: int) -> np.ndarray:
    """Rotor angles at pulse 0 [rev]: float64 [n_motors], given or drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    start = np.asarray(initial_cycles, np.float64) if initial_cycles is not None else rng.uniform(0, 1, n_motors)
    if start.shape != (n_motors,):
        raise ValueError(f"initial_cycles has shape {start.shape}, expected ({n_motors},)")
    return start


def _harmonic_tables(config: SynthesisConfig, table: np.ndarray, amplitudes, fold: int) -> _HarmonicTables:
    """The cached harmonic envelope tables of one rotor table (period 1/``fold`` turn)."""
    bm, alpha = config.blades, config.scaling.alpha_s
    # angles per table period: ENVELOPE_TABLE_SIZE per 1/B turn (more for a full-turn period)
    tsize = ENVELOPE_TABLE_SIZE << (bm.n_blades // fold - 1).bit_length()
    while tsize * fold > TABLE_SIZE:  # many blades: the period 1/B turn is short
        tsize //= 2
    hkey = ("harmonic", bm.n_blades, bm.blade_length_m, bm.wavelength_m, alpha, tsize, ENVELOPE_SPEED_STEP)
    if amplitudes is not None:
        hkey += (amplitudes,)
    henv = _TABLES.get(hkey)
    if henv is None:  # rows are filled lazily for the speeds met and kept for later calls
        if len([k for k in _TABLES if k[0] == "harmonic"]) >= 8:
            for k in [k for k in _TABLES if k[0] == "harmonic"]:
                del _TABLES[k]
        henv = _TABLES[hkey] = _HarmonicTables(table, alpha, fold, tsize, ENVELOPE_SPEED_STEP)
    return henv


class _Kernel:
    """The tables, buffers and rotor phases of one :func:`synthesize` call; chunk by
    chunk, :meth:`blade_signal` gives m(t) (with the margins of the FFT filter),
    :meth:`envelope_filter` applies H(f), :meth:`emit` adds the body and the carrier."""

    def __init__(self, config: SynthesisConfig, n_total: int, start: np.ndarray):
        bm, sc = config.blades, config.scaling
        n_motors = len(start)
        bm.check_motors(n_motors)
        self.config, self.n_total, self.n_motors = config, n_total, n_motors
        self.s_blade = sc.s_blade * bm.gain
        amps = [bm.amplitudes(k) for k in range(n_motors)]
        tables = [_rotor_table(bm.n_blades, bm.blade_length_m, bm.wavelength_m, TABLE_SIZE, a) for a in amps]
        self.carrier = _carrier_table()
        self.shift = 32 - (TABLE_SIZE.bit_length() - 1)
        self.half = 1 << (self.shift - 1)  # rounds the top bits to the nearest table entry
        self.harmonic = config.harmonic
        if self.harmonic:
            # equal blades repeat every 1/B turn: tables over one period, indexed by the
            # B-fold angle B phi; unequal blades repeat once a turn
            fold = bm.n_blades if bm.equal_blades else 1
            henvs = {}
            for a, t in zip(amps, tables):
                if a not in henvs:
                    henvs[a] = _harmonic_tables(config, t, a, fold)
            self.henvs = [henvs[a] for a in amps]
            rshift = 32 - self.henvs[0].bits
            self.inv_step = 1.0 / self.henvs[0].step
        else:
            fold = 1
            self.tables = tables
            rshift = self.shift
        self.rshift = rshift
        self.margin = config.envelope.margin_pulses if config.fft_filter else 0
        mg = self.margin
        chunk = config.chunk_pulses
        if chunk is None:
            chunk = (1 << 17) - 2 * mg if mg < (1 << 15) else 1 << 17
        self.chunk = chunk
        self.scale = PHASE_ONE * fold / config.prf_hz
        # phase at the first pulse of the current chunk, with the rounding half-step
        rhalf = 1 << (rshift - 1)
        self.ph_i0 = [(int(v) + rhalf) & (PHASE_ONE - 1) for v in _fixed_phase(start * fold)]
        blk = min(chunk, n_total) + 2 * mg
        sub = self.sub = min(SUB_BLOCK, blk)
        self.f64 = np.empty(sub, np.float64)
        self.inc = np.empty(sub, np.uint32)
        self.ph = np.empty(sub, np.uint32)
        self.idx = np.empty(sub, np.intp)
        self.tmp = np.empty(sub, np.complex64)
        self.mbuf = np.empty(blk, np.complex64)
        self.cph = np.empty((-(-min(chunk, n_total) // CARRIER_STEP) + 1) * CARRIER_STEP, np.uint32)
        self.cidx = np.empty(self.cph.shape[0], np.intp)
        self.car = np.empty(self.cph.shape[0], np.complex64)
        self.nfft = None
        self.H = None

    def _speed_rows(self, rev_s, a: int, b: int):
        """Harmonic tables: the speeds of pulses [a, b), each motor's row offsets into
        its flat speed-major table and the flat tables. The speed bin k (nearest
        k * step) of each motor is read on the global grid of every
        ENVELOPE_SPEED_STRIDE-th pulse and held for the next stride (the same for any
        chunking)."""
        q = ENVELOPE_SPEED_STRIDE
        g0 = a - a % q
        r_read = np.asarray(rev_s[g0:b])  # one read per chunk
        kf = np.rint(np.asarray(r_read[::q], np.float64).T * self.inv_step)
        if not np.all(np.isfinite(kf)):
            raise ValueError(f"rev_s has non-finite speeds in pulses [{g0}, {b})")
        for h in {id(h): h for h in self.henvs}.values():
            h.cover(int(kf.min()), int(kf.max()))
        koff = [((kf[k] - h.k0) * h.size).astype(np.intp) for k, h in enumerate(self.henvs)]
        return r_read[a - g0 :], koff, [h.table.reshape(-1) for h in self.henvs], g0

    def blade_signal(self, rev_s, a: int, i0: int, i1: int, b: int) -> np.ndarray:
        """m(t) at pulses [a, b) (output pulses [i0, i1) plus the filter margins):
        complex64 [b - a], a view of the chunk buffer. Advances the rotor phases to
        pulse i1."""
        m = self.mbuf[: b - a]
        if not self.config.scaling.s_blade > 0:
            m[:] = 0
            return m
        # rotor phase at pulse a: step back over the margin (exact modulo 2**32)
        cur = [int(v) for v in self.ph_i0]  # Python ints: wrap explicitly, no overflow warnings
        if self.harmonic:
            r_all, koff, rtabs, g0 = self._speed_rows(rev_s, a, b)
        else:
            r_all = np.asarray(rev_s[a:b])  # one read per chunk (Zarr: each stored chunk decoded once)
            rtabs = self.tables
        scale, sub = self.scale, self.sub
        # one range check per chunk instead of per motor and sub-block (with slack for
        # the float32 product in _increments; out of range -> checked per sub-block)
        in_range = bool(r_all.size) and float(r_all.min()) >= 0 and float(r_all.max()) * scale < 0.999 * PHASE_ONE
        for s0 in range(a, i0, sub):
            r = r_all[s0 - a : min(s0 + sub, i0) - a]
            for k in range(self.n_motors):
                d = _increments(r[:, k], scale, self.f64, self.inc, in_range)
                cur[k] = (cur[k] - int(d.sum(dtype=np.uint64))) & (PHASE_ONE - 1)
        bounds = (
            [(s0, min(s0 + sub, i0)) for s0 in range(a, i0, sub)]
            + [(s0, min(s0 + sub, i1)) for s0 in range(i0, i1, sub)]
            + [(s0, min(s0 + sub, b)) for s0 in range(i1, b, sub)]
        )
        idx, tmp, ph = self.idx, self.tmp, self.ph
        for s0, s1 in bounds:
            if s0 == i1:
                self.ph_i0 = list(cur)  # phase at the next chunk's first pulse
            r = r_all[s0 - a : s1 - a]
            n = s1 - s0
            for k in range(self.n_motors):
                d = _increments(r[:, k], scale, self.f64, self.inc, in_range)
                p = ph[:n]
                p[0] = 0
                np.cumsum(d[:-1], out=p[1:])
                p += np.uint32(cur[k])
                cur[k] = (int(p[-1]) + int(d[-1])) & (PHASE_ONE - 1)
                np.right_shift(p, self.rshift, out=idx[:n], casting="unsafe")
                if self.harmonic:
                    _add_row_offsets(idx[:n], s0 - g0, ENVELOPE_SPEED_STRIDE, koff[k])
                # indices are in range by construction; "clip" skips numpy's bounds check
                if k == 0:
                    np.take(rtabs[k], idx[:n], out=m[s0 - a : s1 - a], mode="clip")
                else:
                    np.take(rtabs[k], idx[:n], out=tmp[:n], mode="clip")
                    m[s0 - a : s1 - a] += tmp[:n]
        if b == i1:
            self.ph_i0 = cur
        return m

    def envelope_filter(self, m: np.ndarray, a: int, b: int) -> np.ndarray:
        """H(f) (times the extensions' envelope gain) applied to m(t) at pulses [a, b)
        by FFT, where the FFT filter is in use; else m itself."""
        if not self.config.fft_filter:
            return m
        cfg, mg = self.config, self.margin
        # zeros outside the record: at the record's edges pad by the margin so the
        # circular FFT does not wrap the other end in (same result for any chunking)
        pad = mg if (a == 0 or b == self.n_total) else 0
        n = sfft.next_fast_len(b - a + pad)
        if n != self.nfft:
            self.nfft, self.H = n, envelope_response(n, cfg.prf_hz, cfg.scaling.alpha_s)
            gain = cfg.extensions.envelope_gain
            if gain is not None:
                self.H = (self.H * gain(sfft.fftfreq(n, 1.0 / cfg.prf_hz))).astype(np.complex64)
        M = sfft.fft(m, n, workers=1)
        M *= self.H
        return sfft.ifft(M, workers=1, overwrite_x=True)[: b - a]

    def emit(self, blade: np.ndarray, i0: int, i1: int, track: Track, out: np.ndarray) -> None:
        """out[i0:i1] = (S_blade m + S_body) b(t): the blade signal of pulses [i0, i1)
        (modified in place) scaled and hooked, the body added, times the body carrier."""
        cfg = self.config
        ext, s_body = cfg.extensions, cfg.scaling.s_body
        tt = (
            np.arange(i0, i1, dtype=np.float64) / cfg.prf_hz
            if (ext.blade_hook is not None or ext.body_hook is not None)
            else None
        )
        if self.s_blade != 1:
            blade *= np.float32(self.s_blade)
        if ext.blade_hook is not None:
            ext.blade_hook(i0, i1, tt, blade)
        if ext.body_hook is not None:
            body = np.full(i1 - i0, s_body, np.complex64)
            ext.body_hook(i0, i1, tt, body)
            blade += body
        elif s_body != 0:
            blade += np.float32(s_body)
        cp = _carrier_phase(track, i0, i1, cfg.prf_hz, cfg.wavelength_m, self.half, self.cph)
        ci = np.right_shift(cp, self.shift, out=self.cidx[: i1 - i0], casting="unsafe")
        c = np.take(self.carrier, ci, out=self.car[: i1 - i0], mode="clip")
        np.multiply(blade, c, out=out[i0:i1])


def add_noise(iq: np.ndarray, noise_power: float, seed: int, chunk: int = 1 << 18) -> np.ndarray:
    """Add circular complex white Gaussian noise of ``noise_power`` per pulse, in place.

    Parameters
    ----------
    iq : ndarray, complex64 [n_pulses]
        The signal; modified in place.
    noise_power : float
        Noise power per pulse (linear, the units of ``|iq|^2``).
    seed : int
        Seed of the noise.
    chunk : int
        Pulses drawn at a time (the result does not depend on it).

    Returns
    -------
    ndarray, complex64 [n_pulses]
        ``iq`` itself.

    Examples
    --------
    >>> import numpy as np
    >>> from microdoppler.synthesis import add_noise
    >>> iq = add_noise(np.zeros(100_000, np.complex64), noise_power=0.5, seed=0)
    >>> round(float(np.mean(np.abs(iq) ** 2)), 2)
    0.5
    """
    rng = np.random.default_rng(seed)
    sd = np.sqrt(noise_power / 2)
    for i0 in range(0, len(iq), chunk):
        i1 = min(i0 + chunk, len(iq))
        n = rng.standard_normal((i1 - i0, 2), dtype=np.float32) * np.float32(sd)
        iq[i0:i1] += n[:, 0] + 1j * n[:, 1]
    return iq


def reference_synthesize(config: SynthesisConfig, track: Track, rev_s, *, initial_cycles=None) -> np.ndarray:
    """Straightforward per-pulse evaluation of eq. (1)/(2) (alpha = 0, no extensions;
    per-blade amplitudes and the scattering gain included), for tests and the
    benchmark's reference. Slow on purpose: a Python loop over pulses."""
    import math
    import cmath

    if config.scaling.alpha_s != 0 or config.extensions != ModelExtensions():
        raise ValueError("reference_synthesize evaluates alpha_s = 0 without extensions")
    n, M = rev_s.shape
    bm = config.blades
    bm.check_motors(M)
    k = 4 * math.pi / bm.wavelength_m
    L = bm.blade_length_m
    B = bm.n_blades
    amps = [bm.amplitudes(mm) or (1.0,) * B for mm in range(M)]
    s_blade = config.scaling.s_blade * bm.gain
    cyc = [0.0] * M if initial_cycles is None else list(initial_cycles)
    out = np.empty(n, np.complex64)
    for i in range(n):
        t = i / config.prf_hz
        R = float(track.range_at(t))
        s = 0j
        for mm in range(M):
            for bb in range(B):
                phi = 2 * math.pi * (cyc[mm] + bb / B)
                a = k * L / 2 * math.cos(phi)
                sinc = math.sin(a) / a if a != 0 else 1.0
                s += amps[mm][bb] * L * cmath.exp(-1j * a) * sinc
            cyc[mm] += float(rev_s[i, mm]) / config.prf_hz
        out[i] = (config.scaling.s_body + s_blade * s) * cmath.exp(-1j * 4 * math.pi * R / bm.wavelength_m)
    return out
