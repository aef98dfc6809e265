"""Step 1 of the diagnosis: measure a drone flight against the paper's model of it.

Everything the cause tests (each cause module's, run by
:mod:`microdoppler.diagnosis.hypotheses`) read of a flight is measured here, once,
into one :class:`Measurements`; the tests never go back to the I/Q or the
spectrograms. :func:`measure` first checks that the flight can be diagnosed
(:func:`check_diagnosable`: a drone, blades long enough for visible rotor lines, a
usable motor log, long enough; else :class:`Undiagnosable`), then:

- the flight's STFT: Blackman-Harris *without* high-pass (clutter stays in, so the
  floor around it can be read), on the paper's CPI (``n_fft`` pulses, 50 % overlap);
  frequencies of the target are relative to its body Doppler;
- the paper's model of the flight, simulated once (:func:`simulate_blades`): the blade
  signal of eq. (1) driven by the flight's own motor log (sub-CPI sampling), without
  envelope, on a zero-Doppler track, so its spectrum is body-relative;
- per CPI: the body Doppler and power (with its noise std from the floor at the
  body's distance from the clutter line, :func:`body_floor_ratio`), the HERM line
  spacing measured by matching the measured spectrum to the model's (a frequency
  dilation ``s_t`` of the model's line pattern, :func:`_dilation`), the power of each
  upper and lower sideband (noise-subtracted, with a validity mask that drops
  sidebands on a raised floor, e.g. near clutter) and the model's prediction of each;
- the harmonic pairs visible above the noise (:func:`usable_pairs`) and the paper's
  model calibrated on them (:func:`calibrate`: S_body, S_blade, alpha);
- what the motor log predicts for the line spacing at every lag searched
  (:func:`lag_curves`);
- the body's and the sidebands' power on short windows (:func:`body_power_fine`,
  :func:`sideband_power_fine`), for the fluctuations' correlation times;
- the floor near the clutter line, off the target, with the background recording's
  PSD there (:func:`floor_ordinates`), for the phase-noise test;
- every rotation harmonic of every rotor at its own speed (:func:`rotation_line_powers`):
  identical blades make lines only at multiples of the blade count; the others, which
  a weak or strong blade adds, are read where no other line lies, for the
  blade-imbalance test.

The fixed settings read here are :mod:`microdoppler.causes.config`'s constants.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.fft as sfft

from ..errors import InputError
from ..io.inventory import RADAR_SOURCE
from ..io.motorlog import MotorLog, check_motor_log
from ..rotors import sampling as sampling
from ..spectra.lines import band_power, band_spans, herm_line_hz, local_floor
from ..spectra.periodogram import periodogram, window
from ..synthesis.model import ModelExtensions, Scaling, SynthesisConfig, Track, synthesize
from .config import DiagnosisConfig

DB = 10.0 / np.log(10.0)


# ---------------------------------------------------------------- can it be diagnosed?


class Undiagnosable(InputError):
    """A flight the diagnosis cannot judge (a bird, a Mini, no usable motor log, too
    short, no visible rotor lines). The measurement (and the tests, when nothing is
    left to test) raise it (an :class:`~microdoppler.errors.InputError` naming the
    field); :func:`~microdoppler.diagnosis.diagnose` lists the flight as ``skipped``
    with ``reason``.

    Parameters
    ----------
    source : str
        The flight (its id).
    field : str
        What makes it undiagnosable (``attrs.target``, ``iq``, ``motors/rpm``, ...).
    problem : str
        What is wrong.
    expected : str, optional
        What the diagnosis needs.
    reason : str, optional
        The report's ``reason`` (default: field, problem and expectation).

    Examples
    --------
    >>> from microdoppler.diagnosis import Undiagnosable, diagnose_flight
    >>> from microdoppler.emulator import FlightSpec, emulate_flight
    >>> bird, _ = emulate_flight(FlightSpec("b1", "bird", bird_kind="single", duration_s=1.0, seed=2))
    >>> try:
    ...     diagnose_flight(bird)
    ... except Undiagnosable as err:
    ...     print(err.field)
    attrs.target
    """

    def __init__(self, source, field: str, problem: str, expected: str | None = None, *, reason: str | None = None):
        super().__init__(source, field, problem, expected)
        self.reason = reason or (f"{field}: {problem}" + (f" (expected {expected})" if expected else ""))


def flight_log(flight, motor_log: MotorLog | None) -> MotorLog | None:
    """``motor_log``, else the flight store's own ``motors/*`` log, else None."""
    if motor_log is not None:
        return motor_log
    if flight.has_motor_log:
        return MotorLog(flight.motors_time_s, flight.motors_rpm, str(flight.flight_id))
    return None


def _n_cpis(n_pulses: int, n_fft: int) -> int:
    hop = int(round(n_fft * 0.5))  # stft_power's 50 % overlap
    return 0 if n_pulses < n_fft else 1 + (n_pulses - n_fft) // hop


def log_from_radar(flight, motor_log: MotorLog | None) -> bool:
    """True when the flight's motor log was estimated from this recording's own HERM
    lines (the store's ``motors_source: radar``, or an ingested log so marked)."""
    if motor_log is None:
        return flight.attrs.get("motors_source") == "radar"
    return str(motor_log.source).startswith(RADAR_SOURCE)


def check_diagnosable(flight, motor_log: MotorLog | None, cfg: DiagnosisConfig) -> MotorLog:
    """The flight's motor log, checked; :class:`Undiagnosable` when the flight cannot
    be diagnosed: not a drone, blades too short for visible rotor lines (Minis; not
    when the log was estimated from the recording's own lines, which were seen), no
    motor log, a log that :func:`~microdoppler.io.motorlog.check_motor_log` rejects
    (all zeros, a median speed implausible for a rotor, e.g. rev/s declared as rpm),
    a log covering less than ``min_log_coverage`` of the flight's span, or a flight
    shorter than :meth:`DiagnosisConfig.min_flight_s` (two held-out folds' CPIs)."""
    fid = flight.flight_id
    a = flight.attrs
    target = a.get("target")
    if target != "drone":
        reason = {"bird": "bird flight: no rotors", "none": "target-free recording: no rotors"}.get(
            target, f"target {target!r}: not a drone"
        )
        raise Undiagnosable(fid, "attrs.target", f"is {target!r}", "'drone' (only drones are diagnosed)", reason=reason)
    lam = flight.wavelength_m
    blade = float(a["blade_length_m"])
    log = flight_log(flight, motor_log)
    # rotor speeds measured on this recording's own HERM lines: the lines are visible
    # whatever the blade's length in wavelengths says
    if blade < cfg.min_blade_wavelengths * lam and not (log is not None and log_from_radar(flight, motor_log)):
        size = f"{blade:g} m = {blade / lam:.2f} wavelengths at {flight.carrier_hz / 1e9:.3g} GHz"
        raise Undiagnosable(
            fid,
            "attrs.blade_length_m",
            f"is {size}: the rotor lines are below the noise",
            f">= {cfg.min_blade_wavelengths:g} wavelengths (diagnosis.min_blade_wavelengths)",
            reason=f"{a.get('drone_model', 'drone')}: rotor lines invisible (attrs.blade_length_m {size}, "
            f"< {cfg.min_blade_wavelengths:g})",
        )
    if log is None:
        raise Undiagnosable(
            fid, "motors", "no motor log", "motors/time_s + motors/rpm or a motor log", reason="no motor log"
        )
    t_field, s_field = "motors/time_s", "motors/rpm"
    src = fid if motor_log is None else (log.source or fid)
    try:
        hint = (
            "the speeds were estimated from the radar's HERM lines: check the declared n_blades, prf_hz and "
            "carrier_hz (a wrong blade count reads the comb at another order)"
            if log_from_radar(flight, motor_log)
            else None
        )
        log = check_motor_log(src, log.time_s, log.rpm, unit="rpm", time_field=t_field, speed_field=s_field, hint=hint)
    except InputError as e:
        raise Undiagnosable(
            e.source,
            e.field,
            e.problem,
            e.expected,
            reason=f"unusable motor log: {e.field}: {e.problem}" + (f" (expected {e.expected})" if e.expected else ""),
        ) from None
    span = flight.duration_s
    t0, t1 = float(log.time_s[0]), float(log.time_s[-1])
    cover = max(0.0, min(t1, span) - max(t0, 0.0)) / span
    if cover < cfg.min_log_coverage:
        problem = f"spans {t0:.4g} to {t1:.4g} s, {cover:.0%} of the flight's 0 to {span:.4g} s"
        expected = f">= {cfg.min_log_coverage:.0%} of the flight covered (diagnosis.min_log_coverage)"
        raise Undiagnosable(
            src,
            t_field,
            problem,
            expected,
            reason=f"motor log outside the flight: {t_field}: {problem} (expected {expected})",
        )
    prf = flight.prf_hz
    n_fft = cfg.cpi_pulses(prf)
    n_t = _n_cpis(len(flight.iq), n_fft)
    duration_s = len(flight.iq) / prf
    if n_t < cfg.min_cpis() or duration_s < cfg.min_duration_s:
        problem = f"has {len(flight.iq)} pulses at {prf:g} Hz = {duration_s:.3g} s"
        expected = (
            f">= {cfg.min_flight_s(prf):.3g} s: {cfg.min_cpis()} CPIs of {n_fft / prf:.3g} s, two held-out "
            f"folds of diagnosis.block_cpis={cfg.block_cpis}"
            + (f", and diagnosis.min_duration_s={cfg.min_duration_s:g} s" if cfg.min_duration_s else "")
        )
        raise Undiagnosable(
            fid, "iq", problem, expected, reason=f"flight too short: iq: {problem} (expected {expected})"
        )
    return log


# ---------------------------------------------------------------- spectrogram helpers


@dataclass
class Stft:
    """Power periodogram ``p`` float64 [n_t, n_fft] on centred Doppler ``f_hz``, CPI
    centres ``t_s`` [n_t]; ``window`` the analysis window."""

    p: np.ndarray
    t_s: np.ndarray
    f_hz: np.ndarray
    window: np.ndarray

    @property
    def bin_hz(self) -> float:
        return float(self.f_hz[1] - self.f_hz[0])

    def at(self, f: np.ndarray) -> np.ndarray:
        """Fractional bin index of Doppler ``f`` [Hz]."""
        return (np.asarray(f) - self.f_hz[0]) / self.bin_hz


def stft_power(iq: np.ndarray, prf_hz: float, n_fft: int, overlap: float = 0.5) -> Stft:
    """Blackman-Harris periodogram of every CPI wholly inside ``iq``."""
    hop = int(round(n_fft * (1 - overlap)))
    n_t = 1 + (len(iq) - n_fft) // hop
    if n_t < 1:
        raise ValueError(f"iq has {len(iq)} pulses, fewer than n_fft={n_fft}")
    w = window(n_fft)
    p = periodogram(iq, n_fft, hop=hop, window=w, shift=True)
    t = (np.arange(n_t) * hop + n_fft / 2) / prf_hz
    f = sfft.fftshift(sfft.fftfreq(n_fft, 1.0 / prf_hz))
    return Stft(p, t, f, w)


def noise_power_factor(window: np.ndarray) -> float:
    """kappa = n sum(w^4) / (sum w^2)^2 of the analysis window ``w`` [n] (2.76 for
    Blackman-Harris): the factor by which the periodogram's noise in a band of bins
    varies more than independent bins would.

    The power of a line summed over the band of bins that holds it, minus the
    band's noise, P = sum_k |S_k + N_k|^2 - n_b fl (fl the mean noise per bin), has
    variance kappa (2 P fl + n_b fl^2): the cross term sum_k 2 Re(S_k N_k*) is
    2 Re(n sum_t w_t^2 s_t nu_t*) (Parseval, the band holding the line), of variance
    2 n^2 sigma^2 sum(w^4 |s|^2) = kappa 2 P fl for a line of constant amplitude; and
    the window makes neighbouring bins' noise correlated, sum_d |rho_d|^2 = kappa
    (Parseval again), so the noise term's variance is kappa n_b fl^2. Independent
    bins (kappa = 1) understate the std of the band power by sqrt(2.76) = 1.66 for
    Blackman-Harris (checked by simulation: 2.5-3.0 at 15-40 dB)."""
    w2 = np.asarray(window, float) ** 2
    return float(len(w2) * np.sum(w2**2) / np.sum(w2) ** 2)


def cpi_average(
    t_s: np.ndarray, x: np.ndarray, cpi_t: np.ndarray, window: np.ndarray, prf_hz: float, n_points: int = 64
) -> np.ndarray:
    """Average of the series ``x(t)`` over each CPI, weighted by the window's power
    profile (what a periodogram 'sees'): float [len(cpi_t)] (clamped at the ends)."""
    n = len(window)
    k = np.linspace(0, n - 1, n_points).astype(int)
    wk = window[k] ** 2
    wk = wk / wk.sum()
    tt = cpi_t[:, None] + (k[None, :] - n / 2) / prf_hz
    return (np.interp(tt, t_s, x) * wk).sum(axis=1)


def body_doppler(flight, t_s: np.ndarray) -> np.ndarray:
    """Body Doppler from the track [Hz] at times ``t_s`` (positive = approaching)."""
    v = np.interp(t_s, flight.track_time_s, flight.track_radial_velocity_mps)
    return -2.0 * v / flight.wavelength_m


def refine_peak(st: Stft, f0: np.ndarray, search_hz: float) -> np.ndarray:
    """Strongest bin within ``search_hz`` of ``f0`` per CPI, parabolic-refined [Hz]."""
    out = np.empty(len(f0))
    lp = np.log(st.p + 1e-300)
    for i, fc in enumerate(f0):
        lo = max(1, int(np.floor(st.at(fc - search_hz))))
        hi = min(len(st.f_hz) - 2, int(np.ceil(st.at(fc + search_hz))))
        if hi <= lo:
            out[i] = fc
            continue
        j = lo + int(np.argmax(st.p[i, lo : hi + 1]))
        a, b, c = lp[i, j - 1], lp[i, j], lp[i, j + 1]
        d = 0.5 * (a - c) / (a - 2 * b + c) if (a - 2 * b + c) < 0 else 0.0
        out[i] = st.f_hz[0] + (j + np.clip(d, -0.5, 0.5)) * st.bin_hz
    return out


def simulate_blades(
    log: MotorLog,
    n_pulses: int,
    prf_hz: float,
    *,
    wavelength_m: float,
    n_blades: int,
    blade_length_m: float,
    n_fft: int,
    seed: int,
    extensions: ModelExtensions | None = None,
    alpha_s: float = 0.0,
    s_blade: float = 1.0,
    s_body: float = 0.0,
    track: Track | None = None,
    window_pulses: int = 2500,
    blade_amplitudes=None,
) -> tuple[np.ndarray, np.ndarray]:
    """The paper's model of a flight: returns (iq complex64 [n_pulses], rev_s
    float32 [n_pulses, n_motors]) with sub-CPI sampled speeds of ``log``.

    Without ``track`` the body is at zero Doppler (spectrum relative to the body).
    ``extensions``: model extensions acting inside the synthesis (default none);
    ``blade_amplitudes``: each blade's scattering amplitude (default all 1)."""
    cfg = sampling.SamplingConfig(n_fft=n_fft, window_pulses=window_pulses)
    rev = sampling.sub_cpi(log, n_pulses, prf_hz, cfg)
    dur = n_pulses / prf_hz
    trk = track if track is not None else Track.constant_velocity(1000.0, 0.0, dur)
    ext = extensions if extensions is not None else ModelExtensions()
    if alpha_s > 0 and ext.envelope_gain is None:
        ext = replace(ext, envelope_gain=_unit_envelope)  # the alpha envelope as the FFT filter of eq. (2)
    config = SynthesisConfig.of(
        prf_hz=prf_hz,
        wavelength_m=wavelength_m,
        n_blades=n_blades,
        blade_length_m=blade_length_m,
        scaling=Scaling(s_body, s_blade, alpha_s),
        extensions=ext,
        blade_amplitudes=blade_amplitudes,
    )
    iq = synthesize(config, trk, rev, seed=seed)
    return iq, rev


def _unit_envelope(f_hz):
    return np.ones(len(f_hz), np.float32)


# ---------------------------------------------------------------- what the tests read


@dataclass(frozen=True)
class Calibration:
    """The paper's model fitted to the measurement (:func:`calibrate`): S_body,
    S_blade (relative to S_body) and alpha [s] of the envelope exp(-alpha |f|), the
    per-harmonic blade gain (measured / model sideband-pair power, the model without
    envelope), S_blade absolute (periodogram units of the model), each usable
    harmonic's power error [dB] against the fitted envelope, and their number."""

    s_body: float
    s_blade: float
    alpha_s: float
    blade_gain: np.ndarray
    blade_abs: float
    per_harmonic_power_error_db: dict
    n_usable_harmonics: int


@dataclass(frozen=True)
class FloorOrdinates:
    """The periodogram near the clutter line, off the target, on every second valid
    CPI that has at least 5 such bins (:func:`floor_ordinates`): per CPI ``cpi``
    [n_rows] its body Doppler ``f_body_hz``, body power ``body_pow`` and clutter-line
    power ``clutter_pow`` (noise-subtracted, >= 0), and its bins' Doppler ``f_hz``,
    flight power ``power`` and background PSD ``background`` (one array per row);
    ``bin_hz`` the bin width."""

    bin_hz: float
    cpi: np.ndarray
    f_body_hz: np.ndarray
    body_pow: np.ndarray
    clutter_pow: np.ndarray
    f_hz: tuple
    power: tuple
    background: tuple


@dataclass(frozen=True)
class Measurements:
    """Everything the cause tests read of one flight (module doc); arrays [n_t] (one
    per CPI) unless noted."""

    flight_id: str
    t_s: np.ndarray
    valid: np.ndarray  # bool: CPI usable (body clear of clutter, no artifact, within the log)
    f_body_hz: np.ndarray
    body_pow: np.ndarray  # noise-subtracted body power (periodogram units)
    body_sd_db: np.ndarray  # noise std of 10 log10 body_pow (floor at the body: body_floor_ratio)
    floor: np.ndarray  # far noise floor per bin
    range_m: np.ndarray
    f_log_hz: np.ndarray  # CPI-average of the log's mean motor speed [rev/s]
    dil: np.ndarray  # measured / model line spacing
    dil_ok: np.ndarray  # bool
    harm: np.ndarray  # harmonic numbers used [N]
    up: np.ndarray  # [n_t, N] upper sideband power (noise-subtracted)
    lo: np.ndarray  # [n_t, N] lower
    up_sd: np.ndarray  # [n_t, N] noise std (linear)
    lo_sd: np.ndarray
    pair_ok: np.ndarray  # [n_t, N] bool
    model_h: np.ndarray  # [n_t, N] model (alpha=0, S_blade=1) sideband power, mean of +-n
    usable_pairs: np.ndarray  # [N] bool: weaker side clearly above the noise (usable_pairs)
    usable_pair_sums: np.ndarray  # [N] bool: summed pair clearly above the noise
    lag_s: np.ndarray  # [n_lags] motor-log lags searched [s]
    lag_curves: np.ndarray  # [n_lags, n_t] ln f_log(t + lag) / f_log(t) (lag_curves)
    log: MotorLog  # the checked motor log
    log_from_radar: bool  # the log was estimated from this recording's own HERM lines
    stft: Stft
    bg_stft: Stft | None
    sim_stft: Stft  # the model's blades (alpha = 0, S_blade = 1), body-relative
    body_fine: dict  # short-window body power series (body_power_fine)
    side_fine: dict  # short-window sideband power per harmonic (sideband_power_fine)
    info: dict = field(default_factory=dict)  # spread, prf_hz, n_blades, n_artifact_cpis, match_q
    rot_pow: np.ndarray | None = (
        None  # [n_t, K, 2] power of rotation harmonic k = 1..K, upper/lower (rotation_line_powers)
    )
    rot_var: np.ndarray | None = None  # [n_t, K, 2] its noise variance (the part without the line)
    rot_cross: np.ndarray | None = None  # [n_t, K, 2] variance per unit line power (2 kappa fl)
    rot_n: np.ndarray | None = None  # [n_t, K, 2] int: rotors whose line of order k the sum holds
    rot_wire: np.ndarray | None = None  # [K + 1] one thin-wire blade's line power per rotation harmonic
    calib: Calibration | None = None  # the paper's model calibrated (calibrate)
    floor_ordinates: FloorOrdinates | None = None  # None without a background recording
    side_floor: np.ndarray | None = None  # [n_t, N, 2] local floor per bin at the upper/lower sideband
    side_f_hz: np.ndarray | None = None  # [n_t, N, 2] their Doppler [Hz]
    pair_ok_any_floor: np.ndarray | None = None  # [n_t, N] bool: pair_ok but for the raised-floor guard
    cfg: DiagnosisConfig | None = None  # the settings it was measured with (None: the defaults)


def settings_of(M: Measurements) -> DiagnosisConfig:
    """The settings ``M`` was measured with (:func:`measure`'s ``cfg``), which the
    floor models (:func:`given_imbalance`, :func:`given_skirt`) read again; the
    defaults where ``M`` carries none."""
    return M.cfg if M.cfg is not None else DiagnosisConfig()


def _dilation(st: Stft, sim: Stft, f_body, h0, n_harm, s_grid, floor, clutter_hz):
    """Per-CPI dilation of the model's body-relative blade pattern that best matches
    the measured one (normalised correlation of clipped dB spectra)."""
    n_t = st.p.shape[0]
    df = st.bin_hz
    out = np.full(n_t, np.nan)
    q = np.full(n_t, 0.0)
    for i in range(n_t):
        dmax = (n_harm + 0.5) * h0[i] * s_grid[-1]
        dmin = 0.5 * h0[i] * s_grid[0]
        deltas = np.arange(-dmax, dmax + df, df)
        deltas = deltas[np.abs(deltas) > dmin]
        fm = f_body[i] + deltas
        keep = (np.abs(fm) > clutter_hz) & (np.abs(fm) < st.f_hz[-1])
        deltas, fm = deltas[keep], fm[keep]
        if len(deltas) < 20:
            continue
        m = np.interp(fm, st.f_hz, st.p[i])
        lm = np.clip(DB * np.log(m / floor[i] + 1e-12), 0, 40)
        lm -= lm.mean()
        sp = sim.p[i]
        ref = sp.max()
        ls_full = np.clip(DB * np.log(sp / ref + 1e-12) + 50, 0, 50)
        arg = deltas[None, :] / s_grid[:, None]
        ls = np.interp(arg, sim.f_hz, ls_full)
        ls -= ls.mean(axis=1, keepdims=True)
        num = ls @ lm
        den = np.sqrt((ls**2).sum(axis=1) * (lm**2).sum()) + 1e-12
        c = num / den
        j = int(np.argmax(c))
        if 0 < j < len(s_grid) - 1:
            a, b, cc = c[j - 1], c[j], c[j + 1]
            d = 0.5 * (a - cc) / (a - 2 * b + cc) if (a - 2 * b + cc) < 0 else 0.0
            out[i] = s_grid[j] + np.clip(d, -0.5, 0.5) * (s_grid[1] - s_grid[0])
        else:
            out[i] = s_grid[j]
        q[i] = c[j]
    return out, q


def body_floor_ratio(st: Stft, f_body_hz: np.ndarray, spacing_hz: np.ndarray, cfg, smooth_cpis: int = 2) -> np.ndarray:
    """Floor at the body's distance from the clutter line relative to the far noise
    floor, per CPI (>= 1) [n_t]: the median / ln 2 of the bins whose |f| is within
    ``3 body_half_hz`` of |f_b| (both sides of the clutter line), off the target
    (farther than ``body_half_hz + pn_body_guard_hz`` from the body and than
    ``line_guard_frac`` x the HERM spacing ``spacing_hz`` [n_t] from
    its lines, as in the phase-noise ordinates) and off the clutter line
    (``clutter_guard_hz``), over the median / ln 2 of the whole spectrum; within
    ``6 body_half_hz`` when fewer than 4 bins qualify, 1 when still fewer; averaged
    over +-``smooth_cpis``.

    The body's band holds, besides the body, whatever random floor lies there: the
    thermal noise, and near the clutter line the wind-blown clutter's skirt (10-20 dB
    above the thermal floor at 20-50 Hz on radar 2's site) and the skirt a radar's
    phase noise spreads around the clutter line (about +20 dB at 100 Hz for 0.008 rad
    rms on radar 1, case 111 of tests/test_diagnosis.py). Both are random processes:
    they scatter the band's power like a raised floor, which the far floor does not
    show (body SNR 21-36 dB flights near the clutter named a white body_fluctuation).
    Both are functions of the distance from the clutter line, so they are read at
    the body's distance, off the body's own skirt (a fast fluctuation spreads its
    line: 4.5 dB at 0.08 s raises the bins next to the band ~15 dB at 44 dB SNR) and
    off the blade lines, which are no floor."""
    n_t = len(f_body_hz)
    far = np.median(st.p, axis=1) / np.log(2.0)
    f = st.f_hz
    half = cfg.body_half_hz
    clear = np.abs(f) > cfg.clutter_guard_hz
    r = np.ones(n_t)
    for i in range(n_t):
        fb, sp = f_body_hz[i], spacing_hz[i]
        keep = clear & (np.abs(f - fb) > half + cfg.pn_body_guard_hz)
        if np.isfinite(sp) and sp > 0:
            for n in range(1, 16):
                for sg in (1, -1):
                    keep &= np.abs(f - herm_line_hz(fb, sp, n, sg)) > cfg.line_guard_frac * sp
        dist = np.abs(np.abs(f) - abs(fb))
        for width in (3 * half, 6 * half):
            sel = keep & (dist <= width)
            if sel.sum() >= 4:
                if far[i] > 0:
                    r[i] = float(np.median(st.p[i, sel])) / np.log(2.0) / far[i]
                break
    k = np.ones(2 * smooth_cpis + 1)
    r = np.convolve(r, k, mode="same") / np.convolve(np.ones(n_t), k, mode="same")
    return np.maximum(r, 1.0)


def body_power_fine(
    iq,
    prf_hz: float,
    t_cpi: np.ndarray,
    f_body_hz: np.ndarray,
    valid_cpi: np.ndarray,
    n_fft: int,
    range_t_s=None,
    range_m=None,
    min_fraction: float = 0.4,
    floor_ratio: np.ndarray | None = None,
    divisors: tuple | None = None,
) -> dict:
    """Body power in short windows (Blackman-Harris, 50 % overlap): the body line is
    strong, so its power can be read far faster than the CPI and a fluctuation's
    correlation time resolved down to ~0.05 s.

    The window is the shortest of ``n_fft / d``, d in ``divisors`` (default
    ``DiagnosisConfig.fine_divisors``, 8, 4, 2), for which at least
    ``min_fraction`` of the valid CPIs' windows hold the body clear of the clutter
    line: the stationary clutter is first removed by subtracting the moving average
    over one window (a notch at 0 Hz), and a window's body band (its nearest bin
    +-2 bins) must lie 2.5 bins + 10 Hz from 0 Hz.

    Returns a dict: ``t_s`` [m] window centres, ``y_db`` [m] 10 log10 of the
    noise-subtracted power of the body band (Doppler interpolated from the CPIs),
    ``noise_var_db2`` [m], ``valid`` [m] (the nearest CPI valid, the body clear of
    the clutter and its power > 3 noise std), ``window``, ``hop_s``, ``range_m`` [m],
    ``n_window`` [pulses].

    The noise of a window's band power is that of the floor around the body: the
    far floor times ``floor_ratio`` [n_cpi] (:func:`body_floor_ratio`, of the
    nearest CPI; default 1), through the window (:func:`noise_power_factor`).
    """
    from scipy.ndimage import uniform_filter1d

    x0 = np.asarray(iq, np.complex128)
    out = None
    for d in DiagnosisConfig().fine_divisors if divisors is None else divisors:
        nw = max(64, n_fft // d)
        x = x0 - (uniform_filter1d(x0.real, nw, mode="nearest") + 1j * uniform_filter1d(x0.imag, nw, mode="nearest"))
        st = stft_power(x, prf_hz, nw)
        df = st.bin_hz
        fb = np.interp(st.t_s, t_cpi, f_body_hz)
        floor = np.median(st.p, axis=1) / np.log(2.0)
        jc = np.clip(np.round(st.at(fb)).astype(int), 2, len(st.f_hz) - 3)
        rows = np.arange(len(st.t_s))
        s = sum(st.p[rows, jc + k] for k in range(-2, 3))
        nb = 5.0
        pw = s - nb * floor
        near = np.clip(np.searchsorted(t_cpi, st.t_s), 0, len(t_cpi) - 1)
        fl = floor * (floor_ratio[near] if floor_ratio is not None else 1.0)
        var = noise_power_factor(st.window) * (2 * np.maximum(pw, 0) * fl + nb * fl**2)
        base = valid_cpi[near]
        ok = base & (pw > 3 * np.sqrt(var)) & (np.abs(fb) > 4.5 * df + 10.0)
        y = DB * np.log(np.maximum(pw, 1e-30))
        nv = (DB * np.sqrt(var) / np.maximum(pw, 1e-30)) ** 2
        r = np.interp(st.t_s, range_t_s, range_m) if range_m is not None else np.ones(len(st.t_s))
        out = {
            "t_s": st.t_s,
            "y_db": y,
            "noise_var_db2": nv,
            "valid": ok,
            "window": st.window,
            "hop_s": float(st.t_s[1] - st.t_s[0]) if len(st.t_s) > 1 else float(nw / prf_hz / 2),
            "range_m": r,
            "n_window": int(nw),
        }
        if ok.sum() >= min_fraction * max(base.sum(), 1):
            break
    return out


def sideband_power_fine(
    iq,
    prf_hz: float,
    t_cpi: np.ndarray,
    f_body_hz: np.ndarray,
    spacing_hz: np.ndarray,
    harm: np.ndarray,
    spread: float,
    n_fft: int,
    range_t_s=None,
    range_m=None,
    divisor: int | None = None,
) -> dict:
    """Each HERM harmonic cluster's sideband power in short windows (``n_fft /
    divisor`` pulses, default ``DiagnosisConfig.side_fine_divisor``, 2;
    Blackman-Harris, 50 % overlap), for the fading's correlation time: the CPI grid (a 0.6 s window every 0.3 s) leaves a 1-2 s fading's time
    uncertain by ~20 % over 180 s even to its exact likelihood; on a grid twice as
    fine (0.3 s windows every 0.16 s) the short lags, which carry most of the
    information on T, are seen.

    Per window and harmonic n, the power summed over the whole cluster band (all
    the rotors' lines; centre f_b +- n h, f_b the body Doppler and h the line
    spacing ``spacing_hz``, both interpolated from the CPIs; half width
    n h 2.5 ``spread`` + 3 bins, at most 0.45 h) minus the band's share of the
    window's far floor (median / ln 2), upper and lower side apart. In so short a
    window the rotors' lines (1-3 % apart) are not resolved: their power beats at
    the lines' difference frequencies (n x a few Hz), a nuisance that is
    independent between the harmonics (:func:`.sideband_fading.fading_estimate_fine`
    measures it where the fading cancels). Which harmonics and windows are used is
    left to the caller (the nearest CPI's validity). The stationary clutter is
    first taken out as in :func:`body_power_fine`.

    Returns a dict: ``t_s`` [m] window centres, ``up``, ``lo`` [m, N] noise-subtracted
    powers, ``up_sd``, ``lo_sd`` [m, N] their noise std (linear,
    :func:`noise_power_factor`), ``inside`` [m, N] bool (both bands
    within the Nyquist band), ``cpi`` [m] index of the nearest CPI, ``window``,
    ``hop_s``, ``range_m`` [m], ``n_window`` [pulses].
    """
    from scipy.ndimage import uniform_filter1d

    x0 = np.asarray(iq, np.complex128)
    divisor = DiagnosisConfig().side_fine_divisor if divisor is None else divisor
    nw = max(64, n_fft // divisor)
    x = x0 - (uniform_filter1d(x0.real, nw, mode="nearest") + 1j * uniform_filter1d(x0.imag, nw, mode="nearest"))
    st = stft_power(x, prf_hz, nw)
    del x
    df = st.bin_hz
    nf = len(st.f_hz)
    m = len(st.t_s)
    fb = np.interp(st.t_s, t_cpi, f_body_hz)
    h = np.interp(st.t_s, t_cpi, spacing_hz)
    floor = np.median(st.p, axis=1) / np.log(2.0)
    cs = np.concatenate([np.zeros((m, 1)), np.cumsum(st.p, axis=1)], axis=1)
    rows = np.arange(m)
    kap = noise_power_factor(st.window)
    N = len(harm)
    out = {k: np.zeros((m, N)) for k in ("up", "lo", "up_sd", "lo_sd")}
    inside = np.ones((m, N), bool)
    for k, n in enumerate(np.asarray(harm, float)):
        w = np.minimum(n * h * 2.5 * spread + 3 * df, 0.45 * h)
        for key, sg in (("up", 1.0), ("lo", -1.0)):
            fc = herm_line_hz(fb, h, n, sg)
            a = np.ceil(st.at(fc - w)).astype(int)
            b = np.floor(st.at(fc + w)).astype(int)
            ins = (a >= 0) & (b <= nf - 1) & (b >= a)
            a, b = np.clip(a, 0, nf - 1), np.clip(b, 0, nf - 1)
            nb = np.maximum(b - a + 1, 0)
            s = cs[rows, b + 1] - cs[rows, a]
            pw = s - nb * floor
            out[key][:, k] = pw
            out[key + "_sd"][:, k] = np.sqrt(kap * (2 * np.maximum(pw, 0) * floor + nb * floor**2))
            inside[:, k] &= ins
    near = np.clip(np.searchsorted(t_cpi, st.t_s), 0, len(t_cpi) - 1)
    prev = np.clip(near - 1, 0, len(t_cpi) - 1)
    near = np.where(np.abs(t_cpi[prev] - st.t_s) < np.abs(t_cpi[near] - st.t_s), prev, near)
    r = np.interp(st.t_s, range_t_s, range_m) if range_m is not None else np.ones(m)
    out.update(
        {
            "t_s": st.t_s,
            "inside": inside,
            "cpi": near,
            "window": st.window,
            "hop_s": float(st.t_s[1] - st.t_s[0]) if m > 1 else float(nw / prf_hz / 2),
            "range_m": r,
            "n_window": int(nw),
        }
    )
    return out


def usable_pairs(up, lo, up_sd, lo_sd, pair_ok, *, summed: bool = False, min_snr: float | None = None) -> np.ndarray:
    """Harmonic pairs [N] clearly above the noise in most CPIs: the median over the
    CPIs (where ``pair_ok``) of the weaker side's power over the larger noise std
    (``summed``: of the pair's summed power over its noise std, for a statistic
    that reads the sum, so that a pair with one side weakened by an asymmetry still
    counts) is at least ``min_snr`` (default ``DiagnosisConfig.min_pair_snr``), in at least 6 CPIs.
    ``up``, ``lo``, ``up_sd``, ``lo_sd``, ``pair_ok`` [n_t, N] as in
    :class:`Measurements`."""
    with np.errstate(divide="ignore", invalid="ignore"):
        if summed:
            snr = (up + lo) / np.maximum(np.sqrt(up_sd**2 + lo_sd**2), 1e-30)
        else:
            snr = np.minimum(up, lo) / np.maximum(np.maximum(up_sd, lo_sd), 1e-30)
    snr = np.where(pair_ok, snr, np.nan)
    med = np.array([np.nanmedian(c) if np.isfinite(c).any() else 0.0 for c in snr.T])
    min_snr = DiagnosisConfig().min_pair_snr if min_snr is None else min_snr
    return (med >= min_snr) & (np.isfinite(snr).sum(axis=0) >= 6)


def calibrate(M: Measurements) -> Calibration:
    """S_body, S_blade, alpha of the paper's model fitted to the measurement ``M``, and
    the per-harmonic blade gain used as the model's prediction: each harmonic's
    median measured / model sideband-pair power (``M.model_h``, the model without
    envelope), and over the usable pairs (``M.usable_pairs``) a line in dB over the
    harmonics' frequency n B f (f the median logged speed): its intercept is
    S_blade^2, its slope the envelope's alpha."""
    w2 = float((M.stft.window**2).sum())
    n = len(M.stft.window)
    good = M.valid & (M.body_pow > 0)
    s_body = float(np.sqrt(np.median(M.body_pow[good]) / (n * w2))) if good.any() else float("nan")
    use = M.usable_pairs
    gains = np.ones(len(M.harm))
    for k in range(len(M.harm)):
        mk = M.valid & M.pair_ok[:, k] & (M.model_h[:, k] > 0) & (M.up[:, k] + M.lo[:, k] > 0)
        if mk.sum():
            gains[k] = float(np.median((M.up[mk, k] + M.lo[mk, k]) / (2 * M.model_h[mk, k])))
    hbar = float(np.median(M.f_log_hz)) * M.info["n_blades"]
    ks = np.flatnonzero(use & (gains > 0))
    if len(ks) >= 2:
        slope, icpt = np.polyfit(M.harm[ks] * hbar, 10 * np.log10(gains[ks]), 1)
        alpha = max(0.0, -slope / (20 * np.log10(np.e)))
        s_blade = float(10 ** (icpt / 20))
    elif len(ks) == 1:
        alpha, s_blade = 0.0, float(np.sqrt(gains[ks[0]]))
    else:
        alpha, s_blade = float("nan"), float("nan")
    if not np.isfinite(s_blade):
        s_blade = float(np.sqrt(np.median(gains)))
        alpha = 0.0 if not np.isfinite(alpha) else alpha
    ref = max(s_body, 1e-30)
    per_h_err = {}
    for k in ks:
        pred = s_blade**2 * np.exp(-2 * alpha * M.harm[k] * hbar)
        per_h_err[f"h{int(M.harm[k])}"] = round(float(10 * np.log10(gains[k] / pred)), 2)
    return Calibration(
        s_body=1.0,
        s_blade=s_blade / ref,
        alpha_s=float(alpha),
        blade_gain=gains,
        blade_abs=s_blade,
        per_harmonic_power_error_db=per_h_err,
        n_usable_harmonics=int(len(ks)),
    )


def lag_curves(log: MotorLog, t_s: np.ndarray, window: np.ndarray, prf_hz: float, lags: np.ndarray) -> np.ndarray:
    """g[l, t] = ln f_log(t + lag_l) - ln f_log(t) [len(lags), len(t_s)]: how the line
    spacing the motor ``log`` predicts at the CPIs ``t_s`` changes when the log is
    shifted by each lag [s] (its mean speed CPI-averaged like the sub-CPI sampling,
    :func:`cpi_average`, on shifted CPI centres)."""
    tl = log.time_s
    fl = log.rev_s.mean(axis=1)
    base = cpi_average(tl, fl, t_s, window, prf_hz)
    out = np.empty((len(lags), len(t_s)))
    for i, L in enumerate(lags):
        out[i] = np.log(cpi_average(tl, fl, t_s + L, window, prf_hz) / base)
    return out


def clutter_line_power(M: Measurements) -> np.ndarray:
    """The clutter line's power per CPI [n_t] (periodogram units): the bins within
    ``pn_clutter_line_hz`` (of ``M``'s settings) of 0 Hz, noise-subtracted, >= 0 (read by
    :func:`floor_ordinates` and :func:`skirt_floor`)."""
    st = M.stft
    clutter = np.abs(st.f_hz) <= settings_of(M).pn_clutter_line_hz
    return np.maximum(st.p[:, clutter].sum(axis=1) - clutter.sum() * M.floor, 0.0)


def floor_ordinates(
    M: Measurements, cfg: DiagnosisConfig, *, inner_hz: float | None = None, outer_hz: float | None = None
) -> FloorOrdinates | None:
    """The phase-noise test's data (:class:`FloorOrdinates`; None without a background
    recording): on every second valid CPI (non-overlapping), the periodogram bins
    ``inner_hz`` to ``outer_hz`` (default ``cfg.pn_inner_hz`` to
    ``cfg.pn_outer_hz``) from the clutter line
    (every ``pn_bin_step``-th), off the target: farther than
    ``body_half_hz + pn_body_guard_hz`` from the body, than
    ``line_guard_frac`` x the HERM spacing from its first 15 lines, and
    where the calibrated model's blade power (``M.calib``, smeared lines too) is below
    the floor + ``pn_model_guard_db``; a CPI with fewer than 5 such bins
    is left out. With each bin the background recording's PSD there (same CPI, the
    periodogram smoothed over +-``pn_smooth_cpis`` CPIs and
    +-``pn_smooth_bins`` bins), and per CPI the clutter line's power
    (within ``pn_clutter_line_hz`` of 0 Hz, noise-subtracted); the settings are
    ``cfg``'s."""
    inner_hz = cfg.pn_inner_hz if inner_hz is None else inner_hz
    outer_hz = cfg.pn_outer_hz if outer_hz is None else outer_hz
    if M.bg_stft is None:
        return None
    from scipy.ndimage import uniform_filter

    st, bg = M.stft, M.bg_stft
    k = max(1, int(cfg.pn_smooth_bins))
    # the background recording is the same cell sequence: smooth it over
    # +-pn_smooth_cpis CPIs and +-k bins around each CPI (time-aligned)
    s_bg_t = uniform_filter(bg.p, size=(2 * cfg.pn_smooth_cpis + 1, 2 * k + 1), mode="nearest")
    f = st.f_hz
    region = (np.abs(f) >= inner_hz) & (np.abs(f) <= outer_hz)
    cols = np.flatnonzero(region)[:: cfg.pn_bin_step]
    rows = np.flatnonzero(M.valid)[::2]  # non-overlapping CPIs
    clutter_pow = clutter_line_power(M)
    calib = M.calib
    kept, fs, ps, ss, cs = [], [], [], [], []
    for i in rows:
        fb = M.f_body_hz[i]
        ff = f[cols]
        # off the target: its body skirt and its HERM lines (guard a fraction of the spacing)
        keep = np.abs(ff - fb) > cfg.body_half_hz + cfg.pn_body_guard_hz
        spacing = M.f_log_hz[i] * (M.dil[i] if np.isfinite(M.dil[i]) else 1.0) * int(M.info.get("n_blades", 2))
        for n in range(1, 16):
            for sg in (1, -1):
                keep &= np.abs(ff - herm_line_hz(fb, spacing, n, sg)) > cfg.line_guard_frac * spacing
        n_b = int(M.info.get("n_blades", 2))
        if M.info.get("non_multiple_lines_visible"):
            # a weak or strong blade's lines between the HERM lines (guard as theirs,
            # on the rotation rate's spacing)
            f_rot = spacing / n_b
            for k in range(1, 16 * n_b):
                if k % n_b:
                    for sg in (1, -1):
                        keep &= np.abs(ff - herm_line_hz(fb, f_rot, k, sg)) > cfg.line_guard_frac * f_rot
        if M.sim_stft is not None and calib is not None:
            # off the blade power the calibrated model predicts there (smeared lines too)
            d = ff - fb
            pred = (
                calib.blade_abs**2
                * np.exp(-2 * calib.alpha_s * np.abs(d))
                * np.interp(d, M.sim_stft.f_hz, M.sim_stft.p[i])
            )
            keep &= pred < M.floor[i] * 10 ** (cfg.pn_model_guard_db / 10)
        cc = cols[keep]
        if len(cc) < 5:
            continue
        kept.append(i)
        cs.append(float(clutter_pow[i]))
        fs.append(f[cc])
        ps.append(st.p[i, cc])
        ss.append(s_bg_t[min(i, len(s_bg_t) - 1), cc])
    kept = np.asarray(kept, int)
    return FloorOrdinates(
        bin_hz=st.bin_hz,
        cpi=kept,
        f_body_hz=M.f_body_hz[kept],
        body_pow=M.body_pow[kept],
        clutter_pow=np.asarray(cs, float),
        f_hz=tuple(fs),
        power=tuple(ps),
        background=tuple(ss),
    )


def skirt_shape(f_hz: np.ndarray, bandwidth_hz: float, offset_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """The phase-noise skirt's two shapes at offsets ``f_hz`` [Hz] from its line: flat
    (1 within ``bandwidth_hz``) and sloped ((``offset_hz`` / max(|f|, 20 Hz))^2); the
    phase-noise test fits their mix (:func:`.phase_noise.test_phase_noise`) and
    :func:`skirt_floor` evaluates the fit."""
    with np.errstate(invalid="ignore"):
        return f_hz < bandwidth_hz, (offset_hz / np.maximum(f_hz, 20.0)) ** 2


def skirt_floor(M: Measurements, q_flat: float, q_slope: float, bandwidth_hz: float, offset_hz: float) -> np.ndarray:
    """The floor per bin [n_t, N, 2] that a phase-noise skirt adds at each sideband
    (``M.side_f_hz``): the phase-noise test's model (:func:`.phase_noise.test_phase_noise`),
    (bin / 2 bandwidth) x line power x (q_flat [|f| < bandwidth] + q_slope (offset /
    max(|f|, 20 Hz))^2) around the clutter line (its power, :func:`clutter_line_power`)
    and around the body line (f relative to each)."""
    df = M.stft.bin_hz
    C = clutter_line_power(M)[:, None, None]
    Bt = np.maximum(M.body_pow, 0.0)[:, None, None]
    fc = M.side_f_hz
    out = np.zeros(fc.shape)
    for line, f in ((C, np.abs(fc)), (Bt, np.abs(fc - M.f_body_hz[:, None, None]))):
        flat, slope = skirt_shape(f, bandwidth_hz, offset_hz)
        with np.errstate(invalid="ignore"):
            shape = q_flat * flat + q_slope * slope
        out = out + df / (2 * bandwidth_hz) * line * np.nan_to_num(shape)
    return out


def skirt_ordinates(M: Measurements, cfg: DiagnosisConfig) -> dict | None:
    """The skirt profile's data (:func:`skirt_profile`): the floor ordinates over the
    wide band (:func:`floor_ordinates`, edges ``cfg.pn_inner_hz`` x
    sqrt(2)^k up to ``cfg.pn_profile_outer_hz`` or 0.4 x PRF). Per ordinate
    its power ``P``, the background's ``S``, the bin width times the clutter and body
    lines' powers ``A`` [n, 2], their bands of offset ``jc``/``jb`` (``nb``
    outside), its CPI ``cpi``, side of the clutter line ``pos`` and offset from the
    body ``f_rel_body_hz`` (:data:`ORDINATE_KEYS`); ``edges``, ``nb`` and ``counts``
    (ordinates per clutter band). None without a background recording or with fewer
    than 2 bands of >= 20 ordinates."""
    outer = min(cfg.pn_profile_outer_hz, 0.4 * float(M.info["prf_hz"]))
    edges = [cfg.pn_inner_hz]
    while edges[-1] * np.sqrt(2) <= outer:
        edges.append(edges[-1] * np.sqrt(2))
    edges = np.asarray(edges)
    nb = len(edges) - 1
    if nb < 2:
        return None
    O = floor_ordinates(M, cfg, inner_hz=edges[0], outer_hz=edges[-1])
    if O is None or len(O.cpi) < 4:
        return None
    df = O.bin_hz
    P, S, A, JC, JB, CP = [], [], [], [], [], []
    for j in range(len(O.cpi)):
        fc, fb = O.f_hz[j], O.f_body_hz[j]
        C, Bt = float(O.clutter_pow[j]), max(float(O.body_pow[j]), 0.0)
        P.append(O.power[j])
        S.append(O.background[j])
        CP.append(np.full(len(fc), O.cpi[j]))
        JC.append(np.searchsorted(edges, np.abs(fc), side="right") - 1)
        JB.append(np.searchsorted(edges, np.abs(fc - fb), side="right") - 1)
        A.append(np.column_stack([np.full(len(fc), df * C), np.full(len(fc), df * Bt)]))
    P, S, A, JC, JB, CP = map(np.concatenate, (P, S, A, JC, JB, CP))
    JC = np.where((JC >= 0) & (JC < nb), JC, nb)
    JB = np.where((JB >= 0) & (JB < nb), JB, nb)
    counts = np.bincount(JC[JC < nb], minlength=nb)
    if np.sum(counts >= 20) < 2:
        return None
    F = np.concatenate(O.f_hz)
    FB = np.concatenate([np.full(len(f), fb) for f, fb in zip(O.f_hz, O.f_body_hz)])
    return {
        "P": P,
        "S": S,
        "A": A,
        "jc": JC,
        "jb": JB,
        "cpi": CP,
        "pos": F > 0,
        "f_rel_body_hz": F - FB,
        "edges": edges,
        "nb": nb,
        "counts": counts,
    }


#: the per-ordinate arrays of :func:`skirt_ordinates` (the rest describe the bands)
ORDINATE_KEYS = ("P", "S", "A", "jc", "jb", "cpi", "pos", "f_rel_body_hz")


def ordinate_subset(d: dict, mask: np.ndarray) -> dict:
    """``d`` (:func:`skirt_ordinates`) with only the ordinates where ``mask``."""
    return {k: (v[mask] if k in ORDINATE_KEYS else v) for k, v in d.items()}


def skirt_power(d: dict, levels: np.ndarray, sel=slice(None)) -> np.ndarray:
    """The skirt's power at the ordinates ``sel`` of ``d`` (:func:`skirt_ordinates`)
    for band ``levels`` [nb] (1/Hz): around the clutter line and the body line."""
    Lx = np.r_[np.nan_to_num(levels), 0.0]
    return d["A"][sel, 0] * Lx[d["jc"][sel]] + d["A"][sel, 1] * Lx[d["jb"][sel]]


def robust_skirt_levels(d: dict, sel: np.ndarray | None = None, *, both_sides: bool = False) -> np.ndarray:
    """Band levels [nb] (1/Hz; NaN where a band has < 20 ordinates on both sides of
    the clutter line, or with ``both_sides`` on either side) of the skirt in the
    ordinates ``sel`` of ``d`` (:func:`skirt_ordinates`; default all), robust to the
    target's own lines and
    spread among them (a model that misplaces its lines: a speed scale, a log lag, a
    wrong blade count; a fluctuating body's spread):

    - per band and side of the clutter line, the level at which the median of P / (S
      + skirt) is ln 2, the median of an exponential ordinate over its mean (lines in
      under half of a band's ordinates do not move it); the body's skirt (the same L
      at |f - f_body|) with the other bands' levels, three sweeps;
    - the smaller of the two sides (where both have >= 20 ordinates; with
      ``both_sides``, only there): the radar's skirt lies on both sides of the
      clutter line, the target's lines and spread are not symmetric about it;
    - a skirt falls with offset: levels do not rise outwards (a running minimum from
      the inside)."""
    nb = d["nb"]
    sel = np.ones(len(d["P"]), bool) if sel is None else sel
    sides = []
    for side in (d["pos"], ~d["pos"]):
        ss = sel & side
        fitted = np.bincount(d["jc"][ss][d["jc"][ss] < nb], minlength=nb) >= 20
        lev = np.zeros(nb)
        for _ in range(3):
            for b in np.flatnonzero(fitted):
                s = ss & (d["jc"] == b)
                rest = skirt_power(d, np.where(np.arange(nb) == b, 0.0, lev), s)
                a = d["A"][s, 0] + d["A"][s, 1] * (d["jb"][s] == b)
                base = d["S"][s] + rest
                p = d["P"][s]
                if np.median(p / base) <= np.log(2):
                    lev[b] = 0.0
                    continue
                hi = 1e-14
                while np.median(p / (base + a * hi)) > np.log(2) and hi < 1.0:
                    hi *= 10
                lo = hi / 10
                for _ in range(30):  # on a log scale, to 0.1 %
                    mid = np.sqrt(lo * hi)
                    lo, hi = (mid, hi) if np.median(p / (base + a * mid)) > np.log(2) else (lo, mid)
                lev[b] = hi
        sides.append(np.where(fitted, lev, np.nan))
    both = np.fmin(sides[0], sides[1])  # the smaller side; the one side where only one is fitted
    if both_sides:
        both = np.where(np.isfinite(sides[0]) & np.isfinite(sides[1]), both, np.nan)
    out = np.full(nb, np.nan)
    meas = np.flatnonzero(np.isfinite(both))
    if len(meas):
        out[meas] = np.minimum.accumulate(both[meas])
    return out


def skirt_profile(M: Measurements, cfg: DiagnosisConfig, d: dict | None = None) -> dict | None:
    """The phase-noise skirt's measured profile L(f) [dBc/Hz], piecewise constant in
    bands of offset (:func:`skirt_ordinates`; ``d`` if already read): what a
    phase-noise analyser would plot, read off the target's lines. Each ordinate's
    power is the background recording's PSD plus, per band, L x bin width x (the
    clutter line's power [band of |f|] + the body line's power [band of |f -
    f_body|]); the levels by medians (:func:`robust_skirt_levels`). Bands with fewer
    than 20 ordinates take the log-interpolated level of their neighbours (none
    beyond the last measured band). None without a background recording or with
    fewer than 2 measured bands.

    Returns ``{"band_edges_hz": [...], "dbc_hz": [...], "n_ordinates": [...]}``
    (levels of a band fitted to 0 are -300 dBc/Hz): the phase-noise extension's
    ``skirt_profile`` (:func:`microdoppler.causes.extensions.profile_phase_noise`),
    so the model carries the measured shape, not only its level at 50 Hz."""
    d = skirt_ordinates(M, cfg) if d is None else d
    if d is None:
        return None
    lev = robust_skirt_levels(d)
    meas = np.flatnonzero(np.isfinite(lev))
    if len(meas) < 2:
        return None
    db = np.where(lev[meas] > 0, 10 * np.log10(np.maximum(lev[meas], 1e-300)), -300.0)
    last = meas[-1]
    db = np.interp(np.arange(d["nb"]), meas, db)[: last + 1]
    return {
        "band_edges_hz": [round(float(e), 3) for e in d["edges"][: last + 2]],
        "dbc_hz": [round(float(v), 2) for v in db],
        "n_ordinates": [int(c) for c in d["counts"][: last + 1]],
    }


def given_imbalance(M: Measurements) -> Measurements:
    """``M`` with a named ``blade_imbalance`` in the model of the floor under the
    sidebands: unequal blades put a line at every multiple of the rotation rate, so
    between the blade-passing lines (for two blades, half a spacing from each, at the
    edge of a sideband's local floor) the floor is the target's own rotation lines,
    each smeared by the speed's change within a CPI. A sideband whose local floor is
    raised over the far floor by up to ``rotation_raised_floor_db`` of ``M``'s settings
    (the rotation lines' own guard) is then kept: its power is read over that local floor
    and its noise std taken from it, as always. ``pair_ok``, ``usable_pairs``,
    ``usable_pair_sums`` and the calibration (:func:`calibrate`) follow.

    Without it a weak blade of 3-10 dB can leave no usable pair on Matrice and Inspire
    flights, the paper's model is calibrated on nothing and the sideband causes beside
    the imbalance are not testable."""
    if M.side_floor is None or M.pair_ok_any_floor is None:
        return M
    with np.errstate(invalid="ignore", divide="ignore"):
        rise = DB * np.log(M.side_floor / M.floor[:, None, None])
    cfg = settings_of(M)
    ok = M.pair_ok | (M.pair_ok_any_floor & np.all(rise <= cfg.rotation_raised_floor_db, axis=2))
    if np.array_equal(ok, M.pair_ok):
        return M
    M = replace(
        M,
        pair_ok=ok,
        usable_pairs=usable_pairs(M.up, M.lo, M.up_sd, M.lo_sd, ok, min_snr=cfg.min_pair_snr),
        usable_pair_sums=usable_pairs(M.up, M.lo, M.up_sd, M.lo_sd, ok, summed=True, min_snr=cfg.min_pair_snr),
    )
    return replace(M, calib=calibrate(M))


def given_skirt(
    M: Measurements, q_flat: float, q_slope: float, bandwidth_hz: float, offset_hz: float, *, clear_side: bool = False
) -> Measurements:
    """``M`` with a named phase-noise skirt in the model of the floor under the
    sidebands: a sideband whose local floor is raised over the far floor is kept when
    the far floor plus the skirt (:func:`skirt_floor`) accounts for it to within
    ``raised_floor_db`` of ``M``'s settings (its power is read over its local floor, its noise
    std from that floor, as always); ``pair_ok``, ``usable_pairs`` and
    ``usable_pair_sums`` follow. A skirt of a radar's oscillator lifts the floor
    around the clutter line by up to ~20 dB over 35-400 Hz, where the sidebands of a
    slow body lie; without this, the raised-floor guard drops them and the sideband
    causes cannot be tested.

    The skirt's own noise stays: a sideband on it is read with a larger noise std,
    and one too weak over it is not usable (:func:`usable_pairs`). With
    ``clear_side`` (for a statistic of the pair's summed power, the fading's), a
    harmonic whose one side lies on the skirt and the other clear is read on the
    clear side alone (the sum twice its power, with twice its noise std), in the CPIs
    where that side is clear, whatever the other's floor."""
    if M.side_floor is None or M.pair_ok_any_floor is None:
        return M
    cfg = settings_of(M)
    expected = M.floor[:, None, None] + skirt_floor(M, q_flat, q_slope, bandwidth_hz, offset_hz)
    with np.errstate(invalid="ignore", divide="ignore"):
        fits = np.all(M.side_floor <= expected * 10 ** (cfg.raised_floor_db / 10), axis=2)
    ok = M.pair_ok | (M.pair_ok_any_floor & fits)
    up, lo, up_sd, lo_sd = M.up, M.lo, M.up_sd, M.lo_sd
    if clear_side:
        # a harmonic whose one side lies on a raised floor (over the far floor) and the
        # other clear in most valid CPIs is read on the clear side alone, in every CPI
        # where that side is clear (never mixing sides: a constant asymmetry then
        # cancels against the harmonic's median; a common gain moves both sides)
        with np.errstate(invalid="ignore", divide="ignore"):
            rise = DB * np.log(M.side_floor / M.floor[:, None, None])
        hi = ~(rise <= cfg.raised_floor_db)  # raised (or no floor)
        up, lo, up_sd, lo_sd = up.copy(), lo.copy(), up_sd.copy(), lo_sd.copy()
        ok = ok.copy()
        fine = dict(M.side_fine) if M.side_fine else None
        if fine is not None:
            fine.update({key: np.array(fine[key], copy=True) for key in ("up", "lo", "up_sd", "lo_sd")})
        base = M.pair_ok_any_floor & M.valid[:, None]
        for k in range(up.shape[1]):
            n = base[:, k].sum()
            if n == 0:
                continue
            for j, (a, b) in enumerate((("up", "lo"), ("lo", "up"))):  # side a on the skirt, b clear
                if (base[:, k] & hi[:, k, j] & ~hi[:, k, 1 - j]).sum() < 0.5 * n:
                    continue
                ok[:, k] = M.pair_ok_any_floor[:, k] & ~hi[:, k, 1 - j]
                for arrs in ({"up": up, "lo": lo, "up_sd": up_sd, "lo_sd": lo_sd}, fine):
                    if arrs is not None:
                        # the sum is twice the clear side, its noise std twice that
                        # side's (both halves the same noise): sqrt(2) x each
                        arrs[b + "_sd"][:, k] *= np.sqrt(2.0)
                        arrs[a][:, k], arrs[a + "_sd"][:, k] = arrs[b][:, k], arrs[b + "_sd"][:, k]
                break
        M = replace(M, side_fine=fine if fine is not None else M.side_fine)
    return replace(
        M,
        up=up,
        lo=lo,
        up_sd=up_sd,
        lo_sd=lo_sd,
        pair_ok=ok,
        usable_pairs=usable_pairs(up, lo, up_sd, lo_sd, ok, min_snr=cfg.min_pair_snr),
        usable_pair_sums=usable_pairs(up, lo, up_sd, lo_sd, ok, summed=True, min_snr=cfg.min_pair_snr),
    )


# ---------------------------------------------------------------- the measurement


def non_multiple_visible(power: np.ndarray, noise_var: np.ndarray, n_blades: int, min_z: float) -> bool:
    """Whether the rotation harmonics that are not multiples of ``n_blades`` (a weak or
    strong blade's lines) stand above the noise: median over (CPI, order, side) of
    power / noise std > ``min_z`` (``DiagnosisConfig.non_multiple_visible_z``)."""
    k = np.arange(1, power.shape[1] + 1)
    sel = (k % n_blades) != 0
    z = power[:, sel] / np.sqrt(noise_var[:, sel])
    z = z[np.isfinite(z)]
    return bool(len(z) >= 10 and np.median(z) > min_z)


def thin_wire_line_power(blade_length_m: float, wavelength_m: float, k_max: int, n: int = 4096) -> np.ndarray:
    """The power |c_k|^2 (k = 0..k_max) of the k-th rotation harmonic of ONE thin-wire
    blade of eq. (1), L exp(-j u cos phi) sinc(u cos phi / pi) with u = 2 pi L / lambda,
    as a Fourier series over one revolution (symmetric in k). Identical blades keep only
    the multiples of the blade count; a weak blade lets the others through."""
    phi = 2 * np.pi * np.arange(n) / n
    u = 2 * np.pi * blade_length_m / wavelength_m
    c = np.cos(phi)
    ck = np.fft.fft(np.exp(-1j * u * c) * np.sinc(u * c / np.pi)) / n
    return np.abs(ck[: k_max + 1]) ** 2


def rotation_line_powers(
    st,
    f_body_hz,
    motor_rev_s,
    valid,
    n_blades: int,
    k_max: int,
    floor,
    *,
    clutter_guard_hz: float,
    raised_floor_db: float,
    wander_rel: float | None = None,
):
    """Noise-subtracted power of every rotation harmonic k = 1..k_max on each side of
    the body, summed over the rotors whose line of order k is clear of every other
    rotor's lines of orders k-2..k+2.

    Returns ``(power, noise_var, cross, n_rotors)``: float [n_t, k_max, 2] (side 0
    upper, 1 lower; NaN where not measurable); the variance of ``power`` is
    ``noise_var + cross * power`` (kappa (n_b fl^2 + 2 P fl), :func:`noise_power_factor`);
    int [n_t, k_max, 2], how many rotors' lines the sum holds. A line's band is
    ``wander_rel`` x its order x the rotation rate plus 1.5 bins on each side (default
    ``DiagnosisConfig.rotor_wander_rel``: the speed's wander within a CPI)."""
    wander_rel = DiagnosisConfig().rotor_wander_rel if wander_rel is None else wander_rel
    n_t, n_m = motor_rev_s.shape
    df, nyq = st.bin_hz, st.f_hz[-1]
    kappa = noise_power_factor(st.window)
    P = np.full((n_t, k_max, 2), np.nan)
    V = np.full((n_t, k_max, 2), np.nan)
    W = np.full((n_t, k_max, 2), np.nan)
    R = np.zeros((n_t, k_max, 2), int)
    ks = np.arange(1, k_max + 1)
    sides = np.array([1.0, -1.0])
    # the orders k-2..k+2 (not k, not below 0) whose lines may cover order k's
    k2 = ks[:, None] + np.array([-2, -1, 1, 2])  # [K, 4]
    k2_ok = k2 >= 0
    for i in np.flatnonzero(valid):
        fr = motor_rev_s[i]
        if not np.all(np.isfinite(fr)) or np.any(fr <= 0):
            continue
        p_row = st.p[i]
        # every order, side and rotor at once: [K, 2, n_m] (the others: [K, 2, 4, n_m])
        half = ks[:, None] * fr * wander_rel + 1.5 * df  # [K, n_m]
        cs = herm_line_hz(f_body_hz[i], fr, ks[:, None, None], sides[None, :, None])
        lo, hi = (a.reshape(cs.shape) for a in band_spans(st, cs, np.broadcast_to(half[:, None, :], cs.shape)))
        co = herm_line_hz(f_body_hz[i], fr, k2[:, None, :, None], sides[None, :, None, None])
        olo, ohi = (a.reshape(co.shape) for a in band_spans(st, co, np.broadcast_to(half[:, None, None, :], co.shape)))
        o_on = (olo <= ohi) & k2_ok[:, None, :, None]
        # a rotor's line is clear when no bin of it is one of the other orders'
        over = (olo[:, :, None] <= hi[..., None, None]) & (ohi[:, :, None] >= lo[..., None, None])
        hit = (lo <= hi) & np.any(over & o_on[:, :, None], axis=(3, 4))
        ok = (np.abs(cs) + half[:, None, :] < nyq) & (np.abs(cs) > clutter_guard_hz + half[:, None, :]) & ~hit
        # the floor: the bins within half a rotation rate of the lines' mean, none of
        # them a line of any rotor or order
        wlo, whi = (
            a.reshape(cs.shape[:2]) for a in band_spans(st, cs.mean(axis=-1), np.full(cs.shape[:2], 0.5 * fr.mean()))
        )
        for k, s in zip(*np.nonzero(ok.any(axis=-1) & (whi - wlo + 1 >= 4))):
            b = np.arange(wlo[k, s], whi[k, s] + 1)
            on = o_on[k, s].ravel()
            r_on = lo[k, s] <= hi[k, s]
            a_lo = np.concatenate((olo[k, s].ravel()[on], lo[k, s][r_on]))
            a_hi = np.concatenate((ohi[k, s].ravel()[on], hi[k, s][r_on]))
            near = b[~np.any((a_lo <= b[:, None]) & (b[:, None] <= a_hi), axis=1)]
            if len(near) < 4:
                continue
            fl = float(np.median(p_row[near]) / np.log(2.0))
            if DB * np.log(fl / floor[i]) > raised_floor_db:
                continue
            clear = ok[k, s]
            c_lo, c_hi = lo[k, s][clear], hi[k, s][clear]
            span = np.arange(c_lo.min(), c_hi.max() + 1)
            mine = span[np.any((c_lo <= span[:, None]) & (span[:, None] <= c_hi), axis=1)]
            nb = len(mine)
            P[i, k, s] = float(p_row[mine].sum()) - nb * fl
            V[i, k, s] = kappa * nb * fl**2
            W[i, k, s] = 2 * kappa * fl
            R[i, k, s] = int(clear.sum())
    return P, V, W, R


def measure(flight, motor_log: MotorLog | None = None, cfg: DiagnosisConfig | None = None) -> Measurements:
    """Measure ``flight`` against the paper's model of it (module doc).

    Parameters
    ----------
    flight : microdoppler.io.flightzarr.Flight
        A measured drone flight (``target == "drone"``).
    motor_log : MotorLog, optional
        Its motor log; default the store's ``motors/*`` arrays.
    cfg : DiagnosisConfig, optional

    Raises
    ------
    Undiagnosable
        When the flight cannot be diagnosed (:func:`check_diagnosable`).
    """
    cfg = cfg if cfg is not None else DiagnosisConfig()
    log = check_diagnosable(flight, motor_log, cfg)
    from_radar = log_from_radar(flight, motor_log)
    prf = flight.prf_hz
    a = flight.attrs
    n_fft = cfg.cpi_pulses(prf)
    iq = flight.iq
    st = stft_power(iq, prf, n_fft)
    n_t = len(st.t_s)
    df = st.bin_hz
    floor = np.median(st.p, axis=1) / np.log(2.0)
    # artifact CPIs: floor far above the flight's typical floor
    art = DB * np.log(floor / np.median(floor)) > cfg.raised_floor_db
    # body
    f_trk = body_doppler(flight, st.t_s)
    f_body = refine_peak(st, f_trk, cfg.body_search_hz)
    body_valid = np.abs(f_body) > cfg.clutter_guard_hz + cfg.body_half_hz
    body_pow = np.empty(n_t)
    body_nb = np.empty(n_t)
    for i in range(n_t):
        s, body_nb[i] = band_power(st.p[i], st, f_body[i], cfg.body_half_hz)
        body_pow[i] = s - body_nb[i] * floor[i]
    # the paper's model (blades only, body-relative, alpha = 0)
    sim_iq, rev = simulate_blades(
        log,
        len(iq),
        prf,
        wavelength_m=flight.wavelength_m,
        n_blades=int(a["n_blades"]),
        blade_length_m=float(a["blade_length_m"]),
        n_fft=n_fft,
        seed=cfg.seed,
    )
    sim = stft_power(sim_iq, prf, n_fft)
    t_fine = np.arange(rev.shape[0]) / prf
    step = max(1, int(prf / 200))
    f_log = cpi_average(t_fine[::step], rev[::step].mean(axis=1), st.t_s, st.window, prf)
    spread = float(np.clip(np.median(rev.std(axis=1) / np.maximum(rev.mean(axis=1), 1e-6)), 0, 0.1))
    B = int(a["n_blades"])
    h0 = B * f_log
    s_grid = np.arange(cfg.scale_min, cfg.scale_max + 1e-9, cfg.scale_step)
    dil, q = _dilation(st, sim, f_body, h0, cfg.n_match_harmonics, s_grid, floor, cfg.clutter_guard_hz)
    dil_ok = np.isfinite(dil) & (q > cfg.min_match) & ~art
    dil_f = np.where(np.isfinite(dil), dil, np.nanmedian(dil) if np.isfinite(dil).any() else 1.0)
    # the random part of the body band's power: the floor at the body's distance from
    # the clutter line, off the target (body_floor_ratio), through the window
    # (noise_power_factor)
    fl_ratio = body_floor_ratio(st, f_body, h0 * dil_f, cfg)
    fl_body = floor * fl_ratio
    var = noise_power_factor(st.window) * (2 * np.maximum(body_pow, 0) * fl_body + body_nb * fl_body**2)
    body_sd = DB * np.sqrt(var) / np.maximum(body_pow, 1e-30)
    # sidebands
    N = cfg.n_harmonics
    harm = np.arange(1, N + 1)
    up = np.zeros((n_t, N))
    lo = np.zeros((n_t, N))
    up_sd = np.zeros((n_t, N))
    lo_sd = np.zeros((n_t, N))
    ok = np.zeros((n_t, N), bool)
    # each side's local floor and Doppler, and the pairs good but for a raised floor
    # (given_skirt: a floor raised by a named phase-noise skirt)
    side_fl = np.full((n_t, N, 2), np.nan)
    side_fc = np.full((n_t, N, 2), np.nan)
    ok_any_floor = np.zeros((n_t, N), bool)
    model_h = np.zeros((n_t, N))
    nyq = st.f_hz[-1]
    for i in range(n_t):
        h = h0[i] * dil_f[i]
        hs = h0[i]
        for k, n in enumerate(harm):
            w = max(cfg.line_half_bins * df, n * h * 2.5 * spread + 2 * df)
            w = min(w, 0.4 * h)
            sides = []
            for sgn in (1, -1):
                fc = herm_line_hz(f_body[i], h, n, sgn)
                if abs(fc) + w > nyq:
                    sides.append(None)
                    continue
                s, nb = band_power(st.p[i], st, fc, w)
                fl = local_floor(st.p[i], st, fc, w, 0.5 * h)
                sides.append((s, nb, fl, fc))
            # model
            ms = [band_power(sim.p[i], sim, herm_line_hz(0.0, hs, n, sg), w)[0] for sg in (1, -1)]
            model_h[i, k] = 0.5 * (ms[0] + ms[1])
            if any(x is None for x in sides):
                continue
            good = True
            raised = False
            for j, (s, nb, fl, fc) in enumerate(sides):
                if not np.isfinite(fl) or abs(fc) < cfg.clutter_guard_hz + w:
                    good = False
                elif DB * np.log(fl / floor[i]) > cfg.raised_floor_db:
                    raised = True
                side_fl[i, k, j], side_fc[i, k, j] = fl, fc
                pw = s - nb * fl
                sd = np.sqrt(2 * max(pw, 0) * fl + nb * fl**2)
                if j == 0:
                    up[i, k], up_sd[i, k] = pw, sd
                else:
                    lo[i, k], lo_sd[i, k] = pw, sd
            ok_any_floor[i, k] = good and not art[i]
            ok[i, k] = ok_any_floor[i, k] and not raised
    bg = stft_power(flight.background_iq, prf, n_fft) if flight.background_iq is not None else None
    rng_m = np.interp(st.t_s, flight.track_time_s, flight.track_range_m)
    # CPIs outside the motor log's span: the log's speeds there are unknown
    in_log = (st.t_s >= log.time_s[0]) & (st.t_s <= log.time_s[-1])
    # a body inside the clutter notch for most of the flight (hovering, on a stand, a
    # staring recording): the body line is not measurable, but the rotor lines are,
    # so every CPI counts for them (tests that need the body report not testable)
    body_in_notch = bool(np.median(np.abs(f_body)) <= cfg.clutter_guard_hz + cfg.body_half_hz)
    valid = (body_valid | body_in_notch) & ~art & in_log
    fine = body_power_fine(
        iq,
        prf,
        st.t_s,
        f_body,
        valid,
        n_fft,
        flight.track_time_s,
        flight.track_range_m,
        floor_ratio=fl_ratio,
        divisors=cfg.fine_divisors,
    )
    side_fine = sideband_power_fine(
        iq,
        prf,
        st.t_s,
        f_body,
        h0 * dil_f,
        harm,
        spread,
        n_fft,
        flight.track_time_s,
        flight.track_range_m,
        divisor=cfg.side_fine_divisor,
    )
    lags = np.arange(-cfg.max_lag_s, cfg.max_lag_s + 1e-9, cfg.lag_step_s)
    # every rotation harmonic, per rotor at its own logged speed (times the measured
    # dilation): the blade-passing lines and, between them, what unequal blades add
    rev_m = (
        np.stack(
            [cpi_average(t_fine[::step], rev[::step, m], st.t_s, st.window, prf) for m in range(rev.shape[1])], axis=1
        )
        * dil_f[:, None]
    )
    k_max = B * cfg.n_harmonics
    rot = rotation_line_powers(
        st,
        f_body,
        rev_m,
        in_log & ~art,
        B,
        k_max,
        floor,
        clutter_guard_hz=cfg.clutter_guard_hz,
        raised_floor_db=cfg.rotation_raised_floor_db,
        wander_rel=cfg.rotor_wander_rel,
    )
    rot_wire = thin_wire_line_power(float(a["blade_length_m"]), flight.wavelength_m, k_max)
    M = Measurements(
        flight.flight_id,
        st.t_s,
        valid,
        f_body,
        body_pow,
        body_sd,
        floor,
        rng_m,
        f_log,
        dil,
        dil_ok,
        harm,
        up,
        lo,
        up_sd,
        lo_sd,
        ok,
        model_h,
        usable_pairs=usable_pairs(up, lo, up_sd, lo_sd, ok, min_snr=cfg.min_pair_snr),
        usable_pair_sums=usable_pairs(up, lo, up_sd, lo_sd, ok, summed=True, min_snr=cfg.min_pair_snr),
        lag_s=lags,
        lag_curves=lag_curves(log, st.t_s, st.window, prf, lags),
        log=log,
        log_from_radar=from_radar,
        stft=st,
        bg_stft=bg,
        sim_stft=sim,
        body_fine=fine,
        side_fine=side_fine,
        info={
            "spread": spread,
            "prf_hz": prf,
            "n_blades": B,
            "n_artifact_cpis": int(art.sum()),
            "match_q": float(np.nanmedian(q)),
            "non_multiple_lines_visible": non_multiple_visible(rot[0], rot[1], B, cfg.non_multiple_visible_z),
            "body_in_notch": body_in_notch,
        },
        rot_pow=rot[0],
        rot_var=rot[1],
        rot_cross=rot[2],
        rot_n=rot[3],
        rot_wire=rot_wire,
        side_floor=side_fl,
        side_f_hz=side_fc,
        pair_ok_any_floor=ok_any_floor,
        cfg=cfg,
    )
    # the model calibrated on the measurement, then the floor off the calibrated lines
    M = replace(M, calib=calibrate(M))
    return replace(M, floor_ordinates=floor_ordinates(M, cfg))
