"""Settings of the diagnosis: :class:`DiagnosisConfig` (the ``diagnosis:`` config
section's knobs, each with a physical meaning) and the fixed settings beside it.

A setting is a field of :class:`DiagnosisConfig` when a user has a physical reason to
change it (a site's clutter, a target's body line, how late a motor log may be, what
size of a cause matters). Everything else the diagnosis reads is a module constant
below; its comment says what the value means and names the field it replaced. How
each value was chosen, and the runs that checked the diagnosis as a whole at these
values, are in ``docs/experiments.md``. A config that still sets a replaced field gets
an "unknown key" error naming its constant.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from ..errors import ConfigError, unknown_key
from ..spectra.spectrogram import nearest_power_of_two
from ..configfields import knob

# ---------------------------------------------------------------- fixed settings
# Measurement (measure.py)

#: a floor more than this [dB] above the reference floor is no thermal noise: a CPI
#: whose whole-spectrum floor is this far above the flight's median floor is an
#: artifact CPI (not used), and a sideband whose local floor is this far above its
#: CPI's floor (clutter, another line's skirt) is not read. Replaces two fields
#: (``artifact_floor_db``, ``raised_floor_db``); 3 dB is twice the power.
RAISED_FLOOR_DB = 3.0
#: the same guard for the rotation-rate lines (the blade-imbalance test's observations,
#: :func:`.measure.rotation_line_powers`): their local floor lies between lines of the
#: target itself (a rotor's lines of neighbouring orders, the other rotors' lines of the
#: same order, each smeared by the speed's change within a CPI), which lift it by 5-30 dB
#: on emulated Matrice/Inspire flights while it is still the floor under the line (at
#: 3 dB a weak-blade flight's orders would not be read). The floor is subtracted as
#: measured, the noise variance taken from it; only a floor this far up (no line could
#: be read over it) is refused.
ROTATION_RAISED_FLOOR_DB = 30.0
#: the body line is the strongest bin within this [Hz] of the tracker's Doppler
#: (``body_search_hz``): a radial-speed error of the track up to 1.1 m/s at 1.35 GHz.
BODY_SEARCH_HZ = 10.0
#: the HERM line spacing measured against the model's is searched over dilations
#: SCALE_MIN to SCALE_MAX in steps of SCALE_STEP (``scale_min``, ``scale_max``,
#: ``scale_step``): a speed error of -20 % to +25 %, symmetric in log (SCALE_MAX =
#: 1 / SCALE_MIN), four times the catalog's detectable scale error (|scale - 1| >=
#: 0.05); the step is 1/10 of the relevance margin of a scale (``margin_scale``), and
#: the best step is refined parabolically.
SCALE_MIN = 0.8
SCALE_MAX = 1 / SCALE_MIN
SCALE_STEP = 0.0025
#: harmonics of the HERM pattern matched (``n_match_harmonics``): world v2's
#: fall-offs of up to 16 dB per harmonic leave sidebands that end after one or two
#: pairs.
N_MATCH_HARMONICS = 3
#: a CPI's spacing match is used when the normalised correlation of measured and
#: model patterns exceeds this (``min_match``): below it the pattern is noise.
MIN_MATCH = 0.2
#: sideband pairs read per CPI (``n_harmonics``): harmonics 1-5.
N_HARMONICS = 5
#: least half width of a sideband's band [bins] (``line_half_bins``): the
#: Blackman-Harris main lobe (+-4 bins).
LINE_HALF_BINS = 4
#: a harmonic pair is used when the median over the CPIs of its weaker side's power
#: over its noise std is at least this (``min_pair_snr``), in at least 6 CPIs; the
#: weak-blade flights it leaves untestable say so.
MIN_PAIR_SNR = 5.0
#: step of the motor-log lag grid [s] (``lag_step_s``), refined parabolically: 1/15
#: of the relevance margin of a lag (``margin_lag_s``).
LAG_STEP_S = 0.01
#: phase-noise ordinates: the floor PN_INNER_HZ to PN_OUTER_HZ from the clutter line
#: (``pn_inner_hz``, ``pn_outer_hz``), inside the catalog's phase-noise band (|f| <
#: 100 Hz) and beyond the clutter notch.
PN_INNER_HZ = 35.0
PN_OUTER_HZ = 95.0
#: the measured skirt profile (:func:`.measure.skirt_profile`, the phase-noise
#: extension's shape): bands of offset from PN_PROFILE_INNER_HZ, sqrt(2) apart, up to
#: PN_PROFILE_OUTER_HZ (or 0.4 x PRF). A real skirt need not be flat to 100 Hz: a
#: 1/f-like one reaches a few hundred Hz.
PN_PROFILE_INNER_HZ = PN_INNER_HZ
PN_PROFILE_OUTER_HZ = 1200.0
#: a phase noise is relevant only where the profile's median-based level at 50 Hz is
#: within this many dB below the phase-noise test's fit [dB]: a true skirt agrees to a
#: few dB; where the target's own lines lifted the fit (a wrong blade count, a log lag)
#: the medians find no skirt at all
PN_PROFILE_AGREE_DB = 10.0
#: the wide-band phase-noise reading (:func:`.phase_noise.profile_skirt_test`) uses
#: ordinates at least this far from the body [Hz]: a fluctuating body beside the
#: clutter line spreads on both sides of it
PN_PROFILE_BODY_GUARD_HZ = 100.0
#: ... and only where its levels fall by at least this much [dB] from the innermost
#: band measured on both sides to the outermost: a skirt falls with offset (flat,
#: Gaussian, 1/f-like), the target's own spread (a blade flash over the whole band)
#: does not
PN_PROFILE_FALL_DB = 10.0
#: every PN_BIN_STEP-th bin of the band (``pn_bin_step``): the Whittle likelihood
#: takes its ordinates as independent; the noise of neighbouring Blackman-Harris bins
#: is correlated 0.82, of every second bin 0.44 (4096 pulses).
PN_BIN_STEP = 2
#: the background recording's periodogram, the baseline PSD, smoothed over
#: +-PN_SMOOTH_CPIS CPIs and +-PN_SMOOTH_BINS bins (``pn_smooth_cpis``,
#: ``pn_smooth_bins``): a 5 x 5 average.
PN_SMOOTH_CPIS = 2
PN_SMOOTH_BINS = 2
#: the clutter line's power is summed within this [Hz] of 0 Hz
#: (``pn_clutter_line_hz``): +-2.8 bins of 1.78 Hz (7.3 kHz, 4096 pulses), which hold
#: 99.8-99.97 % of a Blackman-Harris line's power (on a bin, half a bin off).
PN_CLUTTER_LINE_HZ = 5.0
#: the target's HERM lines are avoided by this fraction of their spacing
#: (``pn_line_guard_frac``), in the phase-noise ordinates and the body's floor
#: (measure.body_floor_ratio) on either side of each of the first 15 lines, so the
#: middle 40 % between two lines is read.
LINE_GUARD_FRAC = 0.3
#: ... and the body's own skirt by this [Hz] beyond the body band
#: (``pn_body_guard_hz``): a fluctuating body spreads its line (4.5 dB at 0.08 s
#: raises the bins next to the band ~15 dB at 44 dB SNR, measure.body_floor_ratio).
PN_BODY_GUARD_HZ = 40.0
#: ... and the blade power the calibrated model predicts above this level [dB]
#: relative to the CPI's floor (``pn_model_guard_db``): smeared lines are no floor.
PN_MODEL_GUARD_DB = -10.0

# Tests (hypotheses.py)

#: the body-power statistic is detrended by a moving average over this many CPIs
#: (``body_smooth_cpis``, 2.5 s at 7.3 kHz): slow aspect changes are no
#: fluctuation. The body's sizes and times are estimated on short windows without it
#: (hypotheses.body_estimate).
BODY_SMOOTH_CPIS = 9
#: width [Hz] of the Lorentzian skirt of a fluctuating body, a nuisance column of the
#: phase-noise likelihood in both models (``pn_body_skirt_hz``).
PN_BODY_SKIRT_HZ = 10.0
#: decay lengths [Hz] of extra exponential clutter columns of the phase-noise
#: likelihood (``pn_nuisance_decay_hz``): none. The baseline is the background
#: recording's own PSD, which holds the wind-blown clutter already.
PN_CLUTTER_DECAYS_HZ: tuple = ()

#: removed fields of DiagnosisConfig -> the constant that replaced them (named in
#: the "unknown key" error of a config that still sets one)
REMOVED_FIELDS = {
    "artifact_floor_db": "RAISED_FLOOR_DB",
    "raised_floor_db": "RAISED_FLOOR_DB",
    "body_search_hz": "BODY_SEARCH_HZ",
    "scale_min": "SCALE_MIN",
    "scale_max": "SCALE_MAX",
    "scale_step": "SCALE_STEP",
    "n_match_harmonics": "N_MATCH_HARMONICS",
    "min_match": "MIN_MATCH",
    "n_harmonics": "N_HARMONICS",
    "line_half_bins": "LINE_HALF_BINS",
    "min_pair_snr": "MIN_PAIR_SNR",
    "lag_step_s": "LAG_STEP_S",
    "pn_inner_hz": "PN_INNER_HZ",
    "pn_outer_hz": "PN_OUTER_HZ",
    "pn_bin_step": "PN_BIN_STEP",
    "pn_smooth_cpis": "PN_SMOOTH_CPIS",
    "pn_smooth_bins": "PN_SMOOTH_BINS",
    "pn_clutter_line_hz": "PN_CLUTTER_LINE_HZ",
    "pn_line_guard_frac": "LINE_GUARD_FRAC",
    "pn_body_guard_hz": "PN_BODY_GUARD_HZ",
    "pn_model_guard_db": "PN_MODEL_GUARD_DB",
    "body_smooth_cpis": "BODY_SMOOTH_CPIS",
    "pn_body_skirt_hz": "PN_BODY_SKIRT_HZ",
    "pn_nuisance_decay_hz": "PN_CLUTTER_DECAYS_HZ",
    "margin_body_std_db": "the field margin_std_db",
}


def unknown_key_error(source, key: str, names) -> ConfigError:
    """The :class:`ConfigError` of an unknown ``diagnosis.<key>``; a key that was a
    field before the fixed settings became constants names what replaced it."""
    note = ""
    if key in REMOVED_FIELDS:
        now = REMOVED_FIELDS[key]
        now = now if now.startswith("the field") else f"the constant microdoppler.diagnosis.config.{now}"
        note = f"{key} is no longer a setting: {now}"
    return unknown_key(source, "diagnosis", key, names, note)


# ---------------------------------------------------------------- the config


def _is_int(v) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _is_number(v) -> bool:
    return (_is_int(v) or isinstance(v, (float, np.floating))) and np.isfinite(float(v))


def _check_value(source, key: str, v, kind: str, lo=None, hi=None, lo_open=False, hi_open=False):
    """``v`` as the config value of ``diagnosis.<key>``: type ``kind`` (``int``,
    ``float``, ``bool``) within [lo, hi] (open ends with ``*_open``); else
    :class:`ConfigError` naming ``diagnosis.<key>``."""
    field = f"diagnosis.{key}"
    if kind == "int_or_null":
        return None if v is None else _check_value(source, key, v, "int", lo, hi, lo_open, hi_open)

    def rng_text():
        a = "" if lo is None else (f"> {lo:g}" if lo_open else f">= {lo:g}")
        b = "" if hi is None else (f"< {hi:g}" if hi_open else f"<= {hi:g}")
        if lo is not None and hi is not None:
            return f"in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
        return a or b

    def in_range(x):
        return (lo is None or (x > lo if lo_open else x >= lo)) and (hi is None or (x < hi if hi_open else x <= hi))

    what = {"int": "an integer", "float": "a number", "bool": "true or false"}[kind]
    expected = f"{what} {rng_text()}".strip() if kind != "bool" else what
    if kind == "bool":
        if not isinstance(v, (bool, np.bool_)):
            raise ConfigError(source, field, f"is {v!r} ({type(v).__name__})", expected)
        return bool(v)
    ok_type = _is_int(v) if kind == "int" else _is_number(v)
    if not ok_type:
        if kind == "float" and isinstance(v, (float, np.floating)):
            raise ConfigError(source, field, f"is {v!r}", f"a finite number {rng_text()}".strip())
        raise ConfigError(source, field, f"is {v!r} ({type(v).__name__})", expected)
    x = int(v) if kind == "int" else float(v)
    if not in_range(x):
        raise ConfigError(source, field, f"is {x:g}", expected)
    return x


@dataclass(frozen=True)
class DiagnosisConfig:
    """Settings of the diagnosis (``diagnosis:`` section of the config).

    Parameters
    ----------
    cpi_s : float
        CPI duration [s] of the STFT every statistic is read from (50 % overlap,
        Blackman-Harris): at a flight's PRF the CPI is the power of two of pulses
        nearest ``cpi_s`` x PRF (:meth:`cpi_pulses`), as the spectrogram's
        ``window_s`` gives it. 0.56 s is the paper's STFT, 4096 pulses at 7.3 kHz
        (White et al. §II; ``synthesis.radar.Radar.n_fft``), so the diagnosis sees
        the flight as the classifier's spectrograms do; 1024 pulses at 2 kHz.
    n_fft : int or None
        An explicit CPI length [pulses] that ignores the PRF; None: from ``cpi_s``.
    min_duration_s : float
        Shortest flight diagnosed [s]. A flight needs at least the CPIs of two
        held-out folds of ``block_cpis`` (plus four), whatever this says
        (:meth:`min_flight_s`); 0: that need alone (5.9 s at 7.3 kHz).
    seed : int
        Seed of the paper's model simulated for the flight (sub-CPI speed sampling,
        synthesis): the same seed gives the same report.
    alpha : float
        Family-wise false-alarm level of the held-out tests per flight: Bonferroni
        over the causes, at alpha / (k (k + 1)) for greedy step k
        (``microdoppler.diagnosis.decide.step_threshold``); in (0, 1).
    block_cpis : int
        CPIs per block of the two alternating held-out folds: 8 CPIs = 2.2 s at
        7.3 kHz, longer than the catalog's correlation times (fading 1-2 s), so
        the folds are nearly independent; the calibration's held-out CPIs use the
        same blocks (``datasets.holdout_block_cpis``); >= 1.
    figures : bool
        Write one figure per diagnosed flight (``microdoppler.diagnosis.explain``).
    clutter_guard_hz : float
        Half width [Hz] of the clutter notch: a body or sideband within it of 0 Hz
        is not read. 15 Hz is the paper's high-pass edge (radial speeds below
        1.65 m/s at 1.35 GHz), where the stationary and wind-blown clutter sit.
    body_half_hz : float
        Half width [Hz] of the body line's band: 9 Hz is 5 bins of 1.78 Hz (7.3 kHz
        / 4096), the Blackman-Harris main lobe (+-4 bins) and a bin of Doppler
        wander within a CPI. The body power is summed over it; the guards around
        the body (phase-noise ordinates, the floor at the body) start at its edge.
    model_floor_db : float
        Std [dB] of per-CPI power the paper's model is allowed to miss beyond the
        measurement noise (added in quadrature in the baselines of the fading and
        body tests): 0.5 dB, i.e. 0.25 dB^2 against the 9 dB^2 of the smallest
        detectable fluctuation (3 dB).
    max_lag_s : float
        Longest motor-log lag searched [s], both signs (grid step
        ``LAG_STEP_S``), >= 0.01: twice the largest lag
        ``benchmarks/eval_diagnosis.py`` draws (+-0.3-1.0 s).
    margin_asymmetry_db, margin_std_db, margin_lag_s, margin_scale, margin_floor_rise_db : float
        Relevance margins: a significant cause is named only if its fitted effect
        is at least this, about half the catalog's detectable size: asymmetry
        1.5 dB (detectable >= 3 dB), the std of a fading or body gain 2.0 dB
        (>= 3 dB), lag
        0.15 s (>= 0.3 s), scale 0.025 (>= 0.05), the phase-noise floor rise
        3 dB (>= 6 dB).
    margin_imbalance_db : float
        Relevance margin of a blade imbalance [dB], half the smallest the issue asks
        to find (3 dB): 1.5 dB puts the non-multiple lines 21 dB below the
        blade-passing lines for two blades; balanced flights of the independent
        generator read 0.0 dB (median) at body SNR >= 36 dB.
    margin_excess_db : float
        Goodness of fit: the smallest held-out residual [dB] (measured over the
        fitted model with every named cause's extension, in one Doppler band
        relative to the body) that names ``unexplained``, when it is also
        significant and seen in both folds. 7 dB: the model's own fidelity on flights
        it explains: the smallest whole dB at which at most 2.5 % of explained flights
        read ``unexplained`` on the calibration plan of ``benchmarks/eval_diagnosis.py``
        (the runs: ``docs/experiments.md``).
    margin_common_gain_db : float
        Goodness of fit: the smallest std [dB] of a significant sideband power
        fluctuation that follows the body's (correlation above
        ``microdoppler.causes.sideband_fading.COMMON_GAIN_CORR``, the body moving at least
        ``microdoppler.causes.sideband_fading.COMMON_GAIN_BODY_SHARE`` as many dB) for ``unexplained`` (a gain on the
        whole target: a range-cell straddle, an aspect change; no catalog cause is
        one). 1 dB, half the fading's ``margin_std_db``: slow straddles of under 2 dB std
        are named (the runs that set it: ``docs/experiments.md``).
    min_blade_wavelengths : float
        Blades shorter than this many wavelengths (below the thin wire's half-wave
        resonance) have rotor lines below the noise: such drones (the Mini 2's
        0.06 m blades are 0.27 wavelengths at L-band) are not diagnosed.
    min_log_coverage : float
        Fraction of the flight's time span the motor log must cover; CPIs outside the
        log's span are not used.

    The fixed settings beside these are this module's constants. Invalid values
    raise :class:`~microdoppler.errors.ConfigError` naming ``diagnosis.<field>``
    (:meth:`from_dict` names the config file).

    Raises
    ------
    microdoppler.errors.ConfigError
        From :meth:`from_dict`, for an unknown key or a value out of its range.

    See Also
    --------
    diagnose_flight, diagnose

    Examples
    --------
    >>> from microdoppler.diagnosis import DiagnosisConfig
    >>> cfg = DiagnosisConfig.from_dict({"alpha": 0.05, "figures": False})
    >>> cfg.alpha, cfg.cpi_s, cfg.cpi_pulses(7300.0), cfg.cpi_pulses(2000.0)
    (0.05, 0.56, 4096, 1024)
    >>> DiagnosisConfig.from_dict({"alpah": 0.05})
    Traceback (most recent call last):
    ...
    microdoppler.errors.ConfigError: config: diagnosis.alpah: ...
    """

    cpi_s: float = knob(
        0.56,
        "CPI of the diagnosis's STFT [s]: at a flight's PRF, the power of two of pulses nearest cpi_s x PRF (0.56 "
        "s: 4096 pulses at 7.3 kHz, 1024 at 2 kHz), as spectrogram.window_s.",
        exclusive_minimum=0,
    )
    n_fft: int | None = knob(None, minimum=64)
    min_duration_s: float = knob(
        0.0,
        "Shortest flight diagnosed [s]; a flight also needs the CPIs of two held-out folds of block_cpis plus four "
        "(5.9 s at 7.3 kHz with 0.56 s CPIs). 0: that need alone. A shorter flight is skipped with the minimum in "
        "seconds.",
        minimum=0,
    )
    seed: int = knob(0, minimum=0)
    alpha: float = knob(
        0.01,
        "Family-wise false-alarm level of the held-out likelihood-ratio tests (Bonferroni over the causes).",
        exclusive_minimum=0,
        exclusive_maximum=1,
    )
    block_cpis: int = knob(
        8, "CPIs per block of the two alternating held-out folds (fit on one, score on the other).", minimum=1
    )
    figures: bool = knob(True, "Write one figure per diagnosed flight (measured, baseline, extended, residual).")
    clutter_guard_hz: float = knob(15.0, minimum=0)
    body_half_hz: float = knob(9.0, exclusive_minimum=0)
    model_floor_db: float = knob(0.5, minimum=0)
    max_lag_s: float = knob(2.0, minimum=LAG_STEP_S)
    margin_asymmetry_db: float = knob(1.5, minimum=0)
    margin_std_db: float = knob(2.0, minimum=0)
    margin_lag_s: float = knob(0.15, minimum=0)
    margin_scale: float = knob(0.025, minimum=0)
    margin_floor_rise_db: float = knob(3.0, minimum=0)
    margin_imbalance_db: float = knob(1.5, minimum=0)
    margin_excess_db: float = knob(7.0, minimum=0)
    margin_common_gain_db: float = knob(1.0, minimum=0)
    min_blade_wavelengths: float = knob(0.5, minimum=0)
    min_log_coverage: float = knob(0.5, exclusive_minimum=0, maximum=1)

    @classmethod
    def from_dict(cls, d: dict | None, source="config") -> "DiagnosisConfig":
        """The config of the mapping ``d`` (field -> value); ``source`` (the config
        file) is named in errors: ``<source>: diagnosis.<field>: <problem> (expected ...)``."""
        if d is None:
            d = {}
        if not isinstance(d, dict):
            raise ConfigError(source, "diagnosis", f"is a {type(d).__name__}", "a mapping of diagnosis settings")
        names = [f.name for f in fields(cls)]
        for k in d:
            if k not in names:
                raise unknown_key_error(source, k, names)
        values = {f.name: f.default for f in fields(cls)}
        values.update(d)
        return cls(**_check_config(values, source))

    def cpi_pulses(self, prf_hz: float) -> int:
        """The CPI [pulses] at PRF ``prf_hz`` [Hz]: ``n_fft`` when set, else the power
        of two nearest ``cpi_s`` x ``prf_hz`` (4096 at 7.3 kHz)."""
        if self.n_fft is not None:
            return int(self.n_fft)
        return nearest_power_of_two(self.cpi_s * float(prf_hz))

    def min_cpis(self) -> int:
        """CPIs a flight needs: two held-out folds of ``block_cpis``, plus four."""
        return 2 * self.block_cpis + 4

    def min_flight_s(self, prf_hz: float) -> float:
        """Shortest flight diagnosed at PRF ``prf_hz`` [s]: ``min_duration_s`` or the
        span of :meth:`min_cpis` CPIs of 50 % overlap, whichever is longer."""
        n = self.cpi_pulses(prf_hz)
        need = n + (self.min_cpis() - 1) * int(round(n * 0.5))
        return max(float(self.min_duration_s), need / float(prf_hz))

    def __post_init__(self):
        _check_config({f.name: getattr(self, f.name) for f in fields(self)}, "DiagnosisConfig")


def _rules(cls) -> dict:
    """field -> (kind, lo, hi, lo_open, hi_open): the type and range of each field of
    ``cls``, from its annotation and its :func:`~microdoppler.configfields.knob` (the
    schema's ranges are the same)."""
    kinds = {"float": "float", "int": "int", "bool": "bool", "int | None": "int_or_null"}
    out = {}
    for f in fields(cls):
        m = f.metadata["config"]
        lo = m["exclusive_minimum"] if m["exclusive_minimum"] is not None else m["minimum"]
        hi = m["exclusive_maximum"] if m["exclusive_maximum"] is not None else m["maximum"]
        t = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))
        out[f.name] = (kinds[t], lo, hi, m["exclusive_minimum"] is not None, m["exclusive_maximum"] is not None)
    return out


def _check_config(values: dict, source) -> dict:
    """Every field of ``values`` checked and normalised (ints, floats); raises
    :class:`ConfigError`."""
    return {k: _check_value(source, k, v, *_RULES[k]) for k, v in values.items()}


#: type and allowed range of every DiagnosisConfig field: (kind, lo, hi, lo_open, hi_open)
_RULES = _rules(DiagnosisConfig)
