"""Settings of the diagnosis: :class:`DiagnosisConfig`, the ``diagnosis:`` config
section's knobs (each with a physical meaning) and the fixed settings beside them.

A setting is a configuration key when a user has a physical reason to change it (a
site's clutter, a target's body line, how late a motor log may be, what size of a
cause matters). Every other setting the diagnosis reads is a fixed field of the same
class (``config=False``: no configuration key sets it, the schema leaves it out); its
description says what the value means and names the key it replaced. How each value
was chosen, and the runs that checked the diagnosis as a whole at these values, are in
``docs/experiments.md``. A config that sets a fixed setting, or a key that was replaced,
gets an "unknown key" error naming the fixed field.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from ..errors import ConfigError, unknown_key
from ..spectra.spectrogram import nearest_power_of_two
from ..configfields import check_ranges, config_fields, config_names, knob

#: removed keys of the ``diagnosis:`` section -> the fixed field of DiagnosisConfig that
#: replaced them (named in the "unknown key" error of a config that still sets one);
#: a fixed field's own name is rejected the same way
REMOVED_FIELDS = {
    "artifact_floor_db": "raised_floor_db",
    "pn_line_guard_frac": "line_guard_frac",
    "pn_nuisance_decay_hz": "pn_clutter_decays_hz",
    "margin_body_std_db": "the field margin_std_db",
}


def unknown_key_error(source, key: str, names) -> ConfigError:
    """The :class:`ConfigError` of an unknown ``diagnosis.<key>``; a key that names a
    fixed setting (a ``config=False`` field of :class:`DiagnosisConfig`), or that was a
    key before one replaced it, names that field."""
    note = ""
    fixed = {f.name for f in fields(DiagnosisConfig)} - set(config_names(DiagnosisConfig))
    now = REMOVED_FIELDS.get(key, key if key in fixed else None)
    if now is not None:
        now = now if now.startswith("the field") else f"the fixed setting microdoppler.diagnosis.DiagnosisConfig.{now}"
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
        ``lag_step_s``), >= 0.01: twice the largest lag
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
        ``common_gain_corr``, the body moving at least
        ``common_gain_body_share`` as many dB) for ``unexplained`` (a gain on the
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

    The fields from ``raised_floor_db`` on are fixed settings, no configuration keys
    (``config=False``): each field's description says what it is. Invalid values
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
    max_lag_s: float = knob(2.0, minimum=0.01)
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

    # ------------------------------------------------------------ fixed settings
    # Not configuration keys (config=False: no pipeline key sets them, the schema and
    # the docs' table leave them out, from_dict rejects them); how each value was
    # chosen is in docs/experiments.md. Measurement (measure.py):
    raised_floor_db: float = knob(
        3.0,
        "A floor more than this [dB] above the reference floor is no thermal noise: a CPI whose whole-spectrum "
        "floor is this far above the flight's median floor is an artifact CPI (not used), and a sideband whose "
        "local floor is this far above its CPI's floor (clutter, another line's skirt) is not read. Replaced two "
        "keys (artifact_floor_db, raised_floor_db); 3 dB is twice the power.",
        minimum=0,
        config=False,
    )
    rotation_raised_floor_db: float = knob(
        30.0,
        "The same guard for the rotation-rate lines (the blade-imbalance test's observations, "
        "measure.rotation_line_powers) [dB]: their local floor lies between lines of the target itself (a rotor's "
        "lines of neighbouring orders, the other rotors' lines of the same order, each smeared by the speed's "
        "change within a CPI), which lift it by 5-30 dB on emulated Matrice/Inspire flights while it is still the "
        "floor under the line (at 3 dB a weak-blade flight's orders would not be read). The floor is subtracted "
        "as measured, the noise variance taken from it; only a floor this far up (no line could be read over it) "
        "is refused.",
        minimum=0,
        config=False,
    )
    body_search_hz: float = knob(
        10.0,
        "The body line is the strongest bin within this [Hz] of the tracker's Doppler: a radial-speed error of "
        "the track up to 1.1 m/s at 1.35 GHz.",
        exclusive_minimum=0,
        config=False,
    )
    scale_min: float = knob(
        0.8,
        "The HERM line spacing measured against the model's is searched over dilations scale_min to scale_max in "
        "steps of scale_step: a speed error of -20 % to +25 %, symmetric in log (scale_max = 1 / scale_min), four "
        "times the catalog's detectable scale error (|scale - 1| >= 0.05); the step is 1/10 of the relevance "
        "margin of a scale (margin_scale), and the best step is refined parabolically.",
        exclusive_minimum=0,
        exclusive_maximum=1,
        config=False,
    )
    scale_max: float = knob(1 / 0.8, "See scale_min (1 / scale_min).", exclusive_minimum=1, config=False)
    scale_step: float = knob(0.0025, "See scale_min.", exclusive_minimum=0, config=False)
    n_match_harmonics: int = knob(
        3,
        "Harmonics of the HERM pattern matched: world v2's fall-offs of up to 16 dB per harmonic leave sidebands "
        "that end after one or two pairs.",
        minimum=1,
        config=False,
    )
    min_match: float = knob(
        0.2,
        "A CPI's spacing match is used when the normalised correlation of measured and model patterns exceeds "
        "this: below it the pattern is noise.",
        minimum=-1,
        maximum=1,
        config=False,
    )
    n_harmonics: int = knob(5, "Sideband pairs read per CPI: harmonics 1-5.", minimum=1, config=False)
    line_half_bins: int = knob(
        4,
        "Least half width of a sideband's band [bins]: the Blackman-Harris main lobe (+-4 bins).",
        minimum=0,
        config=False,
    )
    min_pair_snr: float = knob(
        5.0,
        "A harmonic pair is used when the median over the CPIs of its weaker side's power over its noise std is "
        "at least this, in at least 6 CPIs; the weak-blade flights it leaves untestable say so.",
        minimum=0,
        config=False,
    )
    lag_step_s: float = knob(
        0.01,
        "Step of the motor-log lag grid [s], refined parabolically: 1/15 of the relevance margin of a lag "
        "(margin_lag_s).",
        exclusive_minimum=0,
        config=False,
    )
    pn_inner_hz: float = knob(
        35.0,
        "Phase-noise ordinates: the floor pn_inner_hz to pn_outer_hz [Hz] from the clutter line, inside the "
        "catalog's phase-noise band (|f| < 100 Hz) and beyond the clutter notch; the measured skirt profile's "
        "bands start here too.",
        minimum=0,
        config=False,
    )
    pn_outer_hz: float = knob(95.0, "See pn_inner_hz [Hz].", exclusive_minimum=0, config=False)
    pn_profile_outer_hz: float = knob(
        1200.0,
        "The measured skirt profile (measure.skirt_profile, the phase-noise extension's shape): bands of offset "
        "from pn_inner_hz, sqrt(2) apart, up to this [Hz] (or 0.4 x PRF). A real skirt need not be flat to "
        "100 Hz: a 1/f-like one reaches a few hundred Hz.",
        exclusive_minimum=0,
        config=False,
    )
    pn_profile_agree_db: float = knob(
        10.0,
        "A phase noise is relevant only where the profile's median-based level at 50 Hz is within this many dB "
        "below the phase-noise test's fit [dB]: a true skirt agrees to a few dB; where the target's own lines "
        "lifted the fit (a wrong blade count, a log lag) the medians find no skirt at all.",
        minimum=0,
        config=False,
    )
    pn_profile_body_guard_hz: float = knob(
        100.0,
        "The wide-band phase-noise reading (phase_noise.profile_skirt_test) uses ordinates at least this far "
        "from the body [Hz]: a fluctuating body beside the clutter line spreads on both sides of it.",
        minimum=0,
        config=False,
    )
    pn_profile_fall_db: float = knob(
        10.0,
        "... and only where its levels fall by at least this much [dB] from the innermost band measured on both "
        "sides to the outermost: a skirt falls with offset (flat, Gaussian, 1/f-like), the target's own spread "
        "(a blade flash over the whole band) does not.",
        config=False,
    )
    pn_bin_step: int = knob(
        2,
        "Every pn_bin_step-th bin of the phase-noise band: the Whittle likelihood takes its ordinates as "
        "independent; the noise of neighbouring Blackman-Harris bins is correlated 0.82, of every second bin "
        "0.44 (4096 pulses).",
        minimum=1,
        config=False,
    )
    pn_smooth_cpis: int = knob(
        2,
        "The background recording's periodogram, the baseline PSD, is smoothed over +-pn_smooth_cpis CPIs and "
        "+-pn_smooth_bins bins: a 5 x 5 average.",
        minimum=0,
        config=False,
    )
    pn_smooth_bins: int = knob(2, "See pn_smooth_cpis.", minimum=0, config=False)
    pn_clutter_line_hz: float = knob(
        5.0,
        "The clutter line's power is summed within this [Hz] of 0 Hz: +-2.8 bins of 1.78 Hz (7.3 kHz, 4096 "
        "pulses), which hold 99.8-99.97 % of a Blackman-Harris line's power (on a bin, half a bin off).",
        minimum=0,
        config=False,
    )
    line_guard_frac: float = knob(
        0.3,
        "The target's HERM lines are avoided by this fraction of their spacing (replaced the key "
        "pn_line_guard_frac), in the phase-noise ordinates and the body's floor (measure.body_floor_ratio) on "
        "either side of each of the first 15 lines, so the middle 40 % between two lines is read.",
        minimum=0,
        maximum=0.5,
        config=False,
    )
    pn_body_guard_hz: float = knob(
        40.0,
        "... and the body's own skirt by this [Hz] beyond the body band: a fluctuating body spreads its line "
        "(4.5 dB at 0.08 s raises the bins next to the band ~15 dB at 44 dB SNR, measure.body_floor_ratio).",
        minimum=0,
        config=False,
    )
    pn_model_guard_db: float = knob(
        -10.0,
        "... and the blade power the calibrated model predicts above this level [dB] relative to the CPI's floor: "
        "smeared lines are no floor.",
        config=False,
    )
    fine_divisors: tuple = knob(
        (8, 4, 2),
        "Short analysis windows of the body power series tried [pulses] (n_fft / d) (measure.body_power_fine).",
        config=False,
    )
    side_fine_divisor: int = knob(
        2,
        "Short analysis window of the sideband power series (n_fft / d pulses; measure.sideband_power_fine).",
        minimum=1,
        config=False,
    )
    non_multiple_visible_z: float = knob(
        3.0,
        "The lines at non-multiples of the blade count are visible when their median power stands this many "
        "noise standard deviations above zero (then the phase-noise floor keeps off them as off the HERM lines).",
        config=False,
    )
    rotor_wander_rel: float = knob(
        0.025,
        "Relative broadening of one rotor's line within a CPI (its speed wanders ~1 % over a CPI in logged "
        "flights), times the line's order, plus 1.5 bins of window main lobe (measure.rotation_line_powers).",
        minimum=0,
        config=False,
    )
    # Tests (hypotheses.py, the causes' tests):
    body_smooth_cpis: int = knob(
        9,
        "The body-power statistic is detrended by a moving average over this many CPIs (2.5 s at 7.3 kHz): slow "
        "aspect changes are no fluctuation. The body's sizes and times are estimated on short windows without it "
        "(hypotheses.body_estimate).",
        minimum=1,
        config=False,
    )
    pn_body_skirt_hz: float = knob(
        10.0,
        "Width [Hz] of the Lorentzian skirt of a fluctuating body, a nuisance column of the phase-noise "
        "likelihood in both models.",
        exclusive_minimum=0,
        config=False,
    )
    pn_clutter_decays_hz: tuple = knob(
        (),
        "Decay lengths [Hz] of extra exponential clutter columns of the phase-noise likelihood (replaced the key "
        "pn_nuisance_decay_hz): none. The baseline is the background recording's own PSD, which holds the "
        "wind-blown clutter already.",
        config=False,
    )
    log_outlier_frac: float = knob(
        0.05,
        "Outlier fraction of the lag/scale tests' contaminated-normal likelihood (motor_log.test_log): CPIs that "
        "may be outliers of the spacing match (speed steps, a line lost for a CPI).",
        exclusive_minimum=0,
        exclusive_maximum=1,
        config=False,
    )
    common_gain_corr: float = knob(
        0.7,
        "A common sideband gain that correlates more than this with the body power (and moves the body by at "
        "least common_gain_body_share as many dB) is a gain on the whole target (range-cell straddle, aspect), "
        "not a blade fading (sideband_fading.test_fading; the catalog's fading is independent of the body, the "
        "independent generator's fading flights read |r| < 0.3).",
        minimum=-1,
        maximum=1,
        config=False,
    )
    common_gain_body_share: float = knob(
        0.5,
        "The body's dB excursions over the sidebands' (std ratio) that a gain on the whole target gives: it moves "
        "both alike (ratio ~1, the sidebands' noise lowering it). A blade fading moves the body line only by the "
        "blades' share in it (their mean return lies on the body Doppler), well under 0.5 even where it "
        "correlates strongly.",
        minimum=0,
        config=False,
    )
    n_boot: int = knob(
        400,
        "Bootstrap resamples of the blade imbalance's interval (blade_imbalance.imbalance_interval).",
        minimum=1,
        config=False,
    )
    # Explanation (explain.py):
    line_false_alarm: float = knob(
        0.01,
        "The two-sided check's false-alarm probability per flight: a line's presence and its power bounds are "
        "read at this level, Bonferroni over the lines read.",
        exclusive_minimum=0,
        exclusive_maximum=1,
        config=False,
    )
    model_clear_snr_db: float = knob(
        10.0,
        "A model line clearly above the noise: its band's median power at least this far over the noise power "
        "in the band [dB]. Below it, the thin-wire blade's tip edge (which tapered real blades lack) is not taken "
        "for a line the recording should show.",
        config=False,
    )

    @classmethod
    def from_dict(cls, d: dict | None, source="config") -> "DiagnosisConfig":
        """The config of the mapping ``d`` (field -> value); ``source`` (the config
        file) is named in errors: ``<source>: diagnosis.<field>: <problem> (expected ...)``."""
        if d is None:
            d = {}
        if not isinstance(d, dict):
            raise ConfigError(source, "diagnosis", f"is a {type(d).__name__}", "a mapping of diagnosis settings")
        names = config_names(cls)  # the fixed settings (config=False) are no keys
        for k in d:
            if k not in names:
                raise unknown_key_error(source, k, names)
        values = {f.name: f.default for f in config_fields(cls)}
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
        _check_config({f.name: getattr(self, f.name) for f in config_fields(type(self))}, "DiagnosisConfig")
        check_ranges(self, "DiagnosisConfig", all_fields=True)  # the fixed settings' ranges (config=False knobs)


def _rules(cls) -> dict:
    """field -> (kind, lo, hi, lo_open, hi_open): the type and range of each
    configuration key of ``cls``, from its annotation and its
    :func:`~microdoppler.configfields.knob` (the schema's ranges are the same)."""
    kinds = {"float": "float", "int": "int", "bool": "bool", "int | None": "int_or_null"}
    out = {}
    for f in config_fields(cls):
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


#: type and allowed range of every DiagnosisConfig configuration key: (kind, lo, hi, lo_open, hi_open)
_RULES = _rules(DiagnosisConfig)
