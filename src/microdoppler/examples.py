"""Drone recordings from any radar, written from the geometry: a generator independent
of the paper's model.

The documentation's examples use it for a recording from outside the paper's set-up
(:func:`stand_recording`), and it tests the rotor-speed estimator
(:mod:`microdoppler.rotors.speed`, :mod:`microdoppler.rotors.order`) on carriers, PRFs,
rotor counts, blade sets and set-ups the project was not tuned on. It imports only numpy, scipy and
:class:`microdoppler.io.flightzarr.Flight` (the container) and shares no code with
``microdoppler.emulator``, ``microdoppler.synthesis.model``, ``.extensions`` or
``.processes``; its echo is written here from the geometry:

- each blade is a line of point scatterers from the hub (``HUB_FRACTION`` of the
  blade length) to the tip, in ``N_SEGMENTS`` segments of uniform scatterer density
  (each segment summed in closed form: a uniform line of points of total amplitude a
  over [r0, r1] returns a exp(-j k r_mid c) sin(u) / u, u = k (r1 - r0) c / 2, with
  k = 4 pi / lambda and c the cosine between the blade and the line of sight); the
  segment amplitudes (a taper to the tip with a random ripple) are drawn per rotor;
- the rotor plane is level and seen at an elevation ``elevation_deg`` (the blade's
  radial velocity is scaled by its cosine); blade b of rotor m is at angle
  2 pi (Phi_m(t) + b / B) with Phi_m the time integral of the rotation rate;
- ``weak_blade_db`` > 0: one blade of every rotor scatters that much less (amplitude,
  20 log10): the rotor then returns lines at every multiple of its rotation rate,
  not only at multiples of B times it;
- the body is one scatterer on the track (flying: a constant radial speed; hovering:
  a few centimetres of sway, body Doppler ~0 Hz), the clutter a line at 0 Hz with a
  little wind spread, the noise complex white of unit power; all Doppler folds into
  +-PRF/2 as sampling makes it.

Levels: ``body_snr_db`` is the body line over the noise per bin of a 4096-pulse
Blackman-Harris periodogram (the paper's Table III spans ~30-45 dB for drones);
``blade_to_body_db`` the blades' total power relative to the body's, drawn -6 to +6 dB:
at L band, where a blade's power lies in few lines, that puts the first sideband
pair 5-15 dB below the body (the paper, §V.B: 5-10 dB for its large drones); at
higher carriers the same power spreads over more lines, each weaker.

Every parameter of :func:`draw_case` comes from its seed.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np
from scipy.signal.windows import blackmanharris

from microdoppler.io.flightzarr import Flight

C_MPS = 299_792_458.0
SOUND_MPS = 343.0
CARRIERS_HZ = (1.3e9, 3.3e9, 5.8e9, 9.4e9, 24e9)
N_FFT = 4096
N_SEGMENTS = 8
HUB_FRACTION = 0.12
#: the generator's own visibility rule: a first blade-rate pair this far over the noise per bin
VISIBLE_DB = 10.0
#: points per revolution at which a rotor's echo is sampled for its Fourier series
PHASE_GRID = 1024


@dataclass(frozen=True)
class Case:
    """One recording to generate (units in the names)."""

    name: str
    seed: int
    carrier_hz: float
    prf_hz: float
    n_rotors: int
    n_blades: int
    blade_length_m: float
    tip_speed_mps: float
    setup: str  # "hover" (body at ~0 Hz) or "flying"
    weak_blade_db: float  # 0: equal blades
    body_snr_db: float
    blade_to_body_db: float
    elevation_deg: float
    radial_speed_mps: float  # signed, positive receding; 0 when hovering
    clutter_db: float  # clutter line over the noise per bin (4096-pulse periodogram)
    duration_s: float

    @property
    def wavelength_m(self) -> float:
        return C_MPS / self.carrier_hz

    @property
    def rev_s(self) -> float:
        """Nominal rotation rate [rev/s]."""
        return self.tip_speed_mps / (2 * np.pi * self.blade_length_m)

    @property
    def balance(self) -> str:
        return "equal" if self.weak_blade_db == 0 else "one weak blade"


def draw_case(seed: int, *, duration_s: float = 5.0, **fixed) -> Case:
    """A recording's parameters drawn from ``seed`` (any field may be fixed by keyword):
    carrier from :data:`CARRIERS_HZ`, PRF log-uniform 2-20 kHz, 4/6/8 rotors of 2 or 3
    blades, blade length 0.05-0.25 m, tip speed 60-110 m/s (rates 20-400 rev/s),
    hovering or flying, equal blades or one blade 3-10 dB weaker, body SNR 30-45 dB."""
    rng = np.random.default_rng([int(seed), 33])
    carrier = float(rng.choice(CARRIERS_HZ))
    prf = float(np.exp(rng.uniform(np.log(2000.0), np.log(20000.0))))
    n_rotors = int(rng.choice([4, 6, 8]))
    n_blades = int(rng.choice([2, 3]))
    tip = float(rng.uniform(60.0, 110.0))
    lo_l, hi_l = max(0.05, tip / (2 * np.pi * 400.0)), min(0.25, tip / (2 * np.pi * 20.0))
    length = float(rng.uniform(lo_l, hi_l))
    setup = str(rng.choice(["hover", "flying"]))
    weak = 0.0 if rng.uniform() < 0.5 else float(rng.uniform(3.0, 10.0))
    lam = C_MPS / carrier
    if setup == "flying":
        # a radar sees its targets' bodies unaliased: |body Doppler| <= 0.3 PRF
        v = float(rng.uniform(1.0, 12.0))
        v = min(v, 0.3 * prf * lam / 2) * float(rng.choice([-1.0, 1.0]))
        elev = float(rng.uniform(0.0, 30.0))
    else:
        v = 0.0
        elev = float(rng.uniform(0.0, 20.0))
    case = Case(
        name=f"any{seed:04d}",
        seed=int(seed),
        carrier_hz=carrier,
        prf_hz=prf,
        n_rotors=n_rotors,
        n_blades=n_blades,
        blade_length_m=length,
        tip_speed_mps=tip,
        setup=setup,
        weak_blade_db=weak,
        body_snr_db=float(rng.uniform(30.0, 45.0)),
        blade_to_body_db=float(rng.uniform(-6.0, 6.0)),
        elevation_deg=elev,
        radial_speed_mps=v,
        clutter_db=float(rng.uniform(30.0, 60.0)),
        duration_s=float(duration_s),
    )
    return replace(case, **fixed) if fixed else case


def _rotor_speeds(case: Case, rng, tc: np.ndarray) -> np.ndarray:
    """Rotation rates [rev/s], float [n_rotors, len(tc)]: per-rotor offsets, a common
    slow variation and a per-rotor wobble (larger when flying)."""
    hover = case.setup == "hover"
    spread, common_amp, wob_amp = (0.015, 0.01, 0.004) if hover else (0.04, 0.04, 0.01)
    offs = 1 + rng.normal(0.0, spread, case.n_rotors)
    common = 1 + common_amp * np.sin(2 * np.pi * tc / rng.uniform(3.0, 8.0) + rng.uniform(0, 2 * np.pi))
    wob = np.array(
        [
            wob_amp * np.sin(2 * np.pi * tc / rng.uniform(1.0, 3.0) + rng.uniform(0, 2 * np.pi))
            for _ in range(case.n_rotors)
        ]
    )
    rev = case.rev_s * common[None, :] * (offs[:, None] + wob)
    return np.clip(rev, 20.0, 400.0)


def _blade_echo(phi_rev: np.ndarray, case: Case, seg_amp: np.ndarray) -> np.ndarray:
    """One blade's return (unit-free) for rotor angles ``phi_rev`` [rev] per pulse:
    the closed-form sum of each segment's uniform line of point scatterers."""
    k = 4 * np.pi / case.wavelength_m
    c = np.cos(2 * np.pi * phi_rev) * np.cos(np.radians(case.elevation_deg))
    edges = case.blade_length_m * np.linspace(HUB_FRACTION, 1.0, N_SEGMENTS + 1)
    out = np.zeros(len(phi_rev), np.complex128)
    for s in range(N_SEGMENTS):
        mid, half = 0.5 * (edges[s] + edges[s + 1]), 0.5 * (edges[s + 1] - edges[s])
        out += seg_amp[s] * np.exp(-1j * k * mid * c) * np.sinc(k * half * c / np.pi)
    return out


def make_recording(case: Case, *, with_parts: bool = False):
    """The case's recording as a flight-zarr/1 :class:`Flight` (no motor log) and its
    truth: ``{"time_s", "rev_s" [n_t, n_rotors], "body_hz", "visible", "first_pair_db",
    "case"}`` (``visible``: the first blade-rate pair lies unfolded inside +-PRF/2,
    outside +-20 Hz of 0 Hz, and stands ``VISIBLE_DB`` over the noise per bin in the
    mean periodogram of the pair alone: each rotor's Fourier coefficients at orders +-B
    of its rotation rate, on its own phase; the whole blade signal's periodogram near
    +-B f also holds folded higher orders and other rotors' lines, which at 9.4-24 GHz
    stood 7-20 dB over the first pair itself). ``with_parts`` adds the
    noise-free blade signal (``truth["blades"]``)."""
    rng = np.random.default_rng([case.seed, 34])
    prf, lam = case.prf_hz, case.wavelength_m
    n = int(round(case.duration_s * prf))
    t = np.arange(n) / prf
    tc = np.arange(-1.0, case.duration_s + 1.0, 0.005)
    rev_c = _rotor_speeds(case, rng, tc)
    rev = np.array([np.interp(t, tc, r) for r in rev_c])
    phi = np.cumsum(rev, axis=1) / prf + rng.uniform(0, 1, (case.n_rotors, 1))
    # blades: per rotor a segment taper with ripple; one blade weaker where asked
    blades = np.zeros(n, np.complex128)
    first = np.zeros(n, np.complex128)  # the blade-rate pair alone (order +-B of the rotation rate)
    grid = np.arange(PHASE_GRID) / PHASE_GRID
    B = case.n_blades
    for m in range(case.n_rotors):
        x = np.linspace(0, 1, N_SEGMENTS)
        seg = (1.0 - rng.uniform(0.2, 0.7) * x) * np.clip(1 + 0.25 * rng.standard_normal(N_SEGMENTS), 0.3, None)
        weak_b = int(rng.integers(case.n_blades))
        hub_phase = np.exp(1j * rng.uniform(0, 2 * np.pi))
        one_rev = np.zeros(PHASE_GRID, np.complex128)  # the rotor's echo over one revolution
        for b in range(case.n_blades):
            g = 10 ** (-case.weak_blade_db / 20) if (case.weak_blade_db > 0 and b == weak_b) else 1.0
            blades += hub_phase * g * _blade_echo(phi[m] + b / case.n_blades, case, seg)
            one_rev += hub_phase * g * _blade_echo(grid + b / case.n_blades, case, seg)
        c = np.fft.fft(one_rev) / PHASE_GRID
        first += c[B] * np.exp(2j * np.pi * B * phi[m]) + c[-B] * np.exp(-2j * np.pi * B * phi[m])
    blades -= blades.mean()
    # levels
    w = blackmanharris(N_FFT, sym=False)
    a_body = np.sqrt(10 ** (case.body_snr_db / 10) * (w**2).sum() / w.sum() ** 2)
    scale = a_body * 10 ** (case.blade_to_body_db / 20) / np.sqrt(np.mean(np.abs(blades) ** 2))
    blades *= scale
    first *= scale
    # body motion
    if case.setup == "flying":
        r = rng.uniform(200.0, 3000.0) + case.radial_speed_mps * t
        vr = np.full(n, case.radial_speed_mps)
    else:
        amp, per = rng.uniform(0.005, 0.03), rng.uniform(1.0, 4.0)
        ph = rng.uniform(0, 2 * np.pi)
        r0 = rng.uniform(20.0, 500.0)
        r = r0 + amp * np.sin(2 * np.pi * t / per + ph)
        vr = amp * 2 * np.pi / per * np.cos(2 * np.pi * t / per + ph)
    carrier_ph = np.exp(-1j * 4 * np.pi * r / lam)
    echo = (a_body + blades) * carrier_ph
    # clutter at 0 Hz with a Gaussian wind spread (0.3-2 Hz rms), then noise
    a_cl = np.sqrt(10 ** (case.clutter_db / 10) * (w**2).sum() / w.sum() ** 2)
    f = np.fft.fftfreq(n, 1 / prf)
    sd = rng.uniform(0.3, 2.0)
    wind = np.fft.ifft((rng.standard_normal(n) + 1j * rng.standard_normal(n)) * np.exp(-(f**2) / (4 * sd**2)))
    wind *= 0.3 * a_cl / max(np.sqrt(np.mean(np.abs(wind) ** 2)), 1e-30)
    clutter = a_cl * np.exp(1j * rng.uniform(0, 2 * np.pi)) + wind
    noise = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) / np.sqrt(2)
    iq = (echo + clutter + noise).astype(np.complex64)
    # track at 20 Hz
    tt = np.arange(0.0, case.duration_s, 0.05)
    attrs = {
        "schema": "flight-zarr/1",
        "flight_id": case.name,
        "target": "drone",
        "radar_id": "any_radar",
        "prf_hz": float(prf),
        "carrier_hz": float(case.carrier_hz),
        "drone_model": "any_drone",
        "n_motors": int(case.n_rotors),
        "n_blades": int(case.n_blades),
        "blade_length_m": float(case.blade_length_m),
        "source": "microdoppler.examples",
    }
    flight = Flight(
        attrs=attrs,
        iq=iq,
        track_time_s=tt,
        track_range_m=np.interp(tt, t, r),
        track_radial_velocity_mps=np.interp(tt, t, vr),
    )
    body_hz = -2 * case.radial_speed_mps / lam
    first_db = _first_pair_db(first, case, rev.mean(), body_hz)
    fb = case.n_blades * rev.mean()
    visible = bool(
        abs(body_hz) + fb * 1.05 < 0.5 * prf
        and min(abs(body_hz + fb), abs(body_hz - fb)) > 20.0
        and first_db >= VISIBLE_DB
    )
    keep = slice(None, None, max(1, int(prf // 400)))  # speeds at ~400 Hz suffice for CPI means
    truth = {
        "time_s": t[keep],
        "rev_s": rev[:, keep].T,
        "body_hz": float(body_hz),
        "visible": visible,
        "first_pair_db": float(first_db),
        "case": asdict(case),
    }
    if with_parts:
        truth["blades"] = blades
    return flight, truth


def _first_pair_db(blades: np.ndarray, case: Case, mean_rev: float, body_hz: float) -> float:
    """The weaker side of the first blade-rate pair [dB over the noise per bin]: the peak
    of the mean 4096-point periodogram of ``blades`` (the pair alone) within 3 % of +-B f."""
    n = len(blades)
    if n < N_FFT:
        return -np.inf
    w = blackmanharris(N_FFT, sym=False)
    starts = np.arange(0, n - N_FFT + 1, N_FFT // 2)[:8]
    p = np.mean([np.abs(np.fft.fft(blades[s : s + N_FFT] * w)) ** 2 for s in starts], axis=0) / (w**2).sum()
    f = np.fft.fftfreq(N_FFT, 1 / case.prf_hz)
    fb = case.n_blades * mean_rev
    side = []
    for sgn in (1, -1):
        # blade Doppler relative to the body (the blades above carry no carrier phase yet)
        sel = np.abs(f - sgn * fb) <= 0.03 * fb + 2 * case.prf_hz / N_FFT
        side.append(10 * np.log10(p[sel].max() + 1e-30) if sel.any() else -np.inf)
    return float(min(side))


def true_cpi_means(truth: dict, time_s: np.ndarray, n_fft: int, prf_hz: float) -> np.ndarray:
    """True per-rotor speeds averaged over each CPI with the window's power profile
    (Blackman-Harris squared: what a periodogram line's first moment measures):
    float [len(time_s), n_rotors]."""
    w2 = blackmanharris(n_fft, sym=False) ** 2
    k = np.linspace(0, n_fft - 1, 96).astype(int)
    wk = w2[k] / w2[k].sum()
    tt = np.asarray(time_s)[:, None] + (k[None, :] - n_fft / 2) / prf_hz
    rev = np.asarray(truth["rev_s"])
    return np.stack([np.interp(tt, truth["time_s"], rev[:, m]) @ wk for m in range(rev.shape[1])], axis=1)


def rotor_line_spacing_hz(blades: np.ndarray, prf_hz: float, rev_s: float, *, floor_db: float = 30.0):
    """(the lowest line's Doppler, the blade energy's Doppler extent) [Hz] of a noise-free
    blade signal: peaks of its mean 4096-point periodogram within ``floor_db`` of the
    strongest line; the lowest line is the comb's spacing (B f for equal blades, f for
    unequal ones), the extent the farthest such line from 0 Hz (no folding assumed)."""
    w = blackmanharris(N_FFT, sym=False)
    starts = np.arange(0, len(blades) - N_FFT + 1, N_FFT // 2)
    p = np.mean([np.abs(np.fft.fft(blades[s : s + N_FFT] * w)) ** 2 for s in starts], axis=0)
    f = np.fft.fftfreq(N_FFT, 1 / prf_hz)
    db = 10 * np.log10(p + 1e-30)
    peak = (db >= np.roll(db, 1)) & (db >= np.roll(db, -1))
    strong = peak & (db >= db.max() - floor_db) & (np.abs(f) > 0.3 * rev_s)
    return float(np.min(np.abs(f[strong]))), float(np.max(np.abs(f[strong])))


def stand_case(*, seed: int = 7, duration_s: float = 12.0) -> Case:
    """The parameters of ``stand_recording``'s quadcopter on a stand (3.3 GHz CW
    radar at 5 kHz, 4 rotors of two 0.12 m blades at about 160 rev/s, one blade of
    every rotor 6 dB weak, the body at 0 Hz), for ``make_recording``."""
    return draw_case(
        seed,
        duration_s=duration_s,
        carrier_hz=3.3e9,
        prf_hz=5000.0,
        n_rotors=4,
        n_blades=2,
        blade_length_m=0.12,
        tip_speed_mps=2 * np.pi * 0.12 * 160.0,
        setup="hover",
        weak_blade_db=6.0,
        body_snr_db=42.0,
        radial_speed_mps=0.0,
    )


def stand_recording(*, seed: int = 7, duration_s: float = 12.0):
    """A quadcopter on a stand seen by a 3.3 GHz CW radar: the documentation's recording
    from outside the paper's set-up.

    The body hovers at 0 Hz, 25 m away in the sidecar; 4 rotors of 2 blades 0.12 m long
    turn at about 161 rev/s (tip speed of 160 rev/s nominal), one blade of every rotor
    scatters 6 dB less; the radar samples at 5 kHz; there is no motor log.

    Parameters
    ----------
    seed : int
        Seed of every random part (rotor speed variation, scatterer ripple, clutter,
        noise).
    duration_s : float
        Length of the recording [s].

    Returns
    -------
    flight : microdoppler.io.Flight
        The recording (``iq`` complex64 of ``5000 * duration_s`` pulses, a track, no
        motor log).
    truth : dict
        ``"time_s"`` [s] and ``"rev_s"`` [rev/s, float (n_times, 4)]: the rotors' true
        speeds; ``"case"``: the generator's parameters (see ``make_recording``).
    sidecar : dict
        The radar and drone description :func:`microdoppler.importing.import_recording` needs
        with a bare I/Q array (``prf_hz``, ``carrier_hz``, ``n_motors``, ...).

    Examples
    --------
    >>> from microdoppler.examples import stand_recording
    >>> flight, truth, sidecar = stand_recording(duration_s=1.0)
    >>> flight.prf_hz, flight.iq.shape, truth["rev_s"].shape[1]
    (5000.0, (5000,), 4)
    """
    flight, truth = make_recording(stand_case(seed=seed, duration_s=duration_s))
    sidecar = {
        "prf_hz": 5000.0,
        "carrier_hz": 3.3e9,
        "target": "drone",
        "radar_id": "cw_s_band",
        "drone_model": "quad_stand",
        "n_motors": 4,
        "n_blades": 2,
        "blade_length_m": 0.12,
        "range_m": 25.0,
    }
    return flight, truth, sidecar
