"""Direct fidelity of the synthetic twins (Table VI).

Each twin, injected into its flight's background (``results/injected/{variant}.zarr``),
is compared with the measured flight feature by feature, on the CPIs its calibration
did not see (fold B of ``datasets.calibration.holdout_block_cpis``, recorded in the
twin's ``calibration`` attrs).

Per CPI (one timestep of the paper's spectrogram, :mod:`microdoppler.spectra.spectrogram`:
4096-point Blackman-Harris STFT, 50 % overlap), with the body line at the track's
Doppler and the HERM windows at ``body +/- k B f_rot`` from the flight's motor log
(the same ruler for flight and twin, as the calibration's targets use):

- ``line_hz`` [n_harmonics]: body-relative frequency of the k-th HERM line [Hz]: the
  power centroid of the bins >= ``visible_db`` over the median floor within 0.45 line
  spacings of the expected line, on the stronger side (the four rotors make a
  cluster of lines whose strongest member changes from CPI to CPI, so a single peak
  would jump within the cluster), minus the parabolic-refined body peak
  (``diagnosis.measure.refine_peak``); NaN where no bin is visible;
- ``n_pairs``: consecutive sideband pairs from k = 1 whose SNR (the project's one
  measure, ``snr.line_snr_db`` via ``datasets.lines.measure_lines``) is >= ``visible_db``;
- ``first_pair_db``: SNR of the first pair (stronger side) minus the body's [dB];
- ``asymmetry_db``: upper minus lower first sideband [dB];
- ``blade_db``: SNR of the first pair [dB] (its std over time is the blade fading,
  its autocorrelation's 1/e time the fading timescale [s]);
- ``body_db``: body-line SNR [dB] (its std over time);
- ``floor_db``: median power of the bins next to the clutter line, from the
  high-pass edge to ``clutter_span_hz`` beyond it (lines excluded), over the CPI's
  median floor [dB];
- the rotation-rate lines (:func:`rotation_line_sums`): every rotor's lines of order
  k = 1..``rotation_orders`` of its own logged rate (times the CPI's line dilation,
  :func:`line_dilation`, which absorbs a log's scale or lag), noise-subtracted
  (``diagnosis.measure.rotation_line_powers``); per CPI the summed power of the lines
  at non-multiples of the blade count and the summed reference of the blade-passing
  lines beside them (geometric mean, each over one thin wire's own line power times
  order k's: the envelope and the wire's pattern cancel;
  ``diagnosis.hypotheses.non_multiple_observations``), where both blade-passing
  lines stand 3 noise std above the floor. The flight statistic ``nonmultiple_db``
  is 10 log10 of their ratio over the scored CPIs: for two blades of amplitudes a and
  1, 20 log10 |1 - a| / (1 + a); eq. (1)'s identical blades give none: a ratio below
  ``nonmultiple_z`` times its noise standard deviation (the lines' noise variance,
  ``diagnosis.measure.noise_power_factor``) reads ``nonmultiple_floor_db``, as does
  any level below that floor; NaN where the blade-passing lines are seen in fewer
  than ``nonmultiple_min_cpis`` of the scored CPIs (weak blades).

A hovering or stand-mounted drone has its body line in the clutter notch (no CPI's
body peak beyond ``highpass_hz + search_hz``, :func:`body_in_notch`): its lines are
then placed and measured about the track's body Doppler instead of the body peak
(the rotor lines stand symmetric about it, outside the notch), and the features read
on the body line (``first_pair_db``, ``body_std_db``) are not measured (NaN).

Per flight and feature one distance between twin and flight (:func:`distances`): the
mean |delta f| over the measured flight's visible harmonics (k = 1 when none is
visible) and the scored CPIs for ``line_hz``, and |twin - measured| of the
flight-level statistic (mean, std or timescale over the scored CPIs) for the others.
Table VI (:func:`fidelity_table`) gives per variant the mean distance over flights
with a 95 % flight-bootstrap interval, and paired variant differences.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..configfields import check_keys, check_ranges, config_names, knob
from ..stats.bootstrap import N_BOOT, draw_flights, interval, ratio_replicates, resolved
from .calibration import CalibrationConfig
from .injection import INJECTED_SCHEMA
from .lines import body_doppler_hz, log_rate_at, measure_lines
from .split import TWIN_MODELS, twin_model
from .stores import flight_ids, open_store, put_array, writing_store
from ..causes.config import DiagnosisConfig
from ..causes.blade_imbalance import non_multiple_observations
from ..causes.heldout import folds
from ..causes.measure import Stft, refine_peak, rotation_line_powers, thin_wire_line_power
from ..errors import InputError
from ..io.flightzarr import read_flight
from ..io.inventory import list_flights, read_ingested_log
from ..io.outputs import atomic_file
from ..spectra.lines import herm_line_hz
from ..spectra.snr import noise_floor_db
from ..spectra.periodogram import window
from ..spectra.spectrogram import Spectrogram, SpectrogramConfig, spectrogram

#: distances of Table VI (name: unit), in column order
DISTANCES = {
    "line_hz": "Hz",
    "n_pairs": "pairs",
    "first_pair_db": "dB",
    "asymmetry_db": "dB",
    "blade_std_db": "dB",
    "blade_timescale_s": "s",
    "body_std_db": "dB",
    "floor_db": "dB",
    "nonmultiple_db": "dB",
}
#: the paper's ordering of the sampling variants (sub-CPI > per-CPI ~ single-motor >
#: fixed-speeds, as Table V's; classifier.reports is not imported: it needs torch)
ORDER = ("sub_cpi", "per_cpi", "single_motor", "fixed_speeds")


def pairs(variants) -> list[tuple[str, str]]:
    """Paired differences reported: neighbours in :data:`ORDER` among the variants
    present (sub_cpi - fixed_speeds when only those two are built), then
    ``extended - sub_cpi``."""
    chain = [v for v in ORDER if v in variants]
    out = list(zip(chain[:-1], chain[1:]))
    return out + ([("extended", "sub_cpi")] if {"extended", "sub_cpi"} <= set(variants) else [])


@dataclass(frozen=True)
class FidelityReport:
    """The fidelity report's bootstrap (config ``fidelity:``, beside
    :class:`~microdoppler.datasets.fidelity.FidelityConfig`'s keys)."""

    n_boot: int = knob(2000, "Bootstrap replicates (flights drawn with replacement) of the 95 % intervals.", minimum=1)
    seed: int = knob(0, "Seed of the bootstrap draws.")


@dataclass(frozen=True)
class FidelityConfig:
    """Settings of the feature measurement.

    Parameters
    ----------
    visible_db : float
        SNR at or above which a sideband pair counts as visible [dB].
    search_hz : float
        Search half-width of the body line and base half-width of the sidebands [Hz].
    n_harmonics : int
        Sideband pairs measured.
    clutter_span_hz : float
        Width of the band next to the clutter line (beyond the high-pass edge) whose
        floor is read [Hz].
    max_lag_cpis : int
        Longest lag of the blade-power autocorrelation [CPIs]; a timescale that is
        not reached is reported as this lag (censored).
    rotation_orders : int
        Rotation harmonics k = 1..rotation_orders measured per rotor (``nonmultiple_db``).
    nonmultiple_floor_db : float
        Floor of ``nonmultiple_db`` [dB]: lines below it count as absent (a 3 dB
        imbalance of two blades puts them at -15.3 dB).
    dilation_range : float
        The CPI's line dilation (:func:`line_dilation`) is searched within
        1 +- dilation_range.
    nonmultiple_z : float
        The non-multiple lines count as seen when their summed power exceeds this many
        noise standard deviations; else ``nonmultiple_db`` is the floor.
    nonmultiple_min_cpis : int
        ``nonmultiple_db`` needs the blade-passing reference in at least this many
        scored CPIs (else NaN: not measured).
    dilation_step : float
        Grid step of the line dilation's search (:func:`line_dilation`).
    dilation_smooth_cpis : int
        CPIs of the line dilation's running median.
    nonmultiple_min_z : float
        The blade-passing lines used as the non-multiple lines' reference stand this
        many noise standard deviations above the floor.
    """

    visible_db: float = knob(10.0, config=False)
    search_hz: float = knob(10.0, config=False)
    n_harmonics: int = knob(6, config=False)
    clutter_span_hz: float = knob(
        30.0,
        "Width of the band next to the clutter line, beyond the spectrogram's high-pass edge, whose floor is "
        "compared [Hz].",
        exclusive_minimum=0,
    )
    max_lag_cpis: int = knob(
        16,
        "Longest lag of the blade-power autocorrelation [CPIs]; a fading timescale beyond it is reported as this "
        "lag (censored).",
        minimum=1,
    )
    rotation_orders: int = knob(8, config=False)
    nonmultiple_floor_db: float = knob(-30.0, config=False)
    dilation_range: float = knob(0.15, config=False)
    nonmultiple_z: float = knob(3.0, config=False)
    nonmultiple_min_cpis: int = knob(10, config=False)
    dilation_step: float = knob(0.0025, exclusive_minimum=0, config=False)
    dilation_smooth_cpis: int = knob(9, minimum=1, config=False)
    nonmultiple_min_z: float = knob(3.0, config=False)

    def __post_init__(self):
        if not self.search_hz > 0:
            raise ValueError(f"search_hz={self.search_hz} must be > 0")
        if self.n_harmonics < 1:
            raise ValueError(f"n_harmonics={self.n_harmonics} must be >= 1")
        if not self.clutter_span_hz > 0:
            raise ValueError(f"clutter_span_hz={self.clutter_span_hz} must be > 0")
        if self.max_lag_cpis < 1:
            raise ValueError(f"max_lag_cpis={self.max_lag_cpis} must be >= 1")
        if self.rotation_orders < 1:
            raise ValueError(f"rotation_orders={self.rotation_orders} must be >= 1")
        if not 0 <= self.dilation_range < 1:
            raise ValueError(f"dilation_range={self.dilation_range} must be in [0, 1)")
        check_ranges(self, "fidelity", all_fields=True)  # the config=False knobs' ranges too

    @classmethod
    def from_config(cls, fidelity: dict, calibration: dict, search_hz: float, source="config") -> "FidelityConfig":
        """From the config's ``fidelity:`` and ``datasets.calibration:`` sections and
        ``datasets.snr_search_hz`` (the calibration's visibility and harmonics, so
        the twins are scored as they were fitted). An unknown key of either section
        is a one-line :class:`~microdoppler.errors.ConfigError` naming it."""
        fidelity = check_keys(fidelity, [*config_names(cls), *config_names(FidelityReport)], "fidelity", source)
        calibration = check_keys(calibration, config_names(CalibrationConfig), "datasets.calibration", source)
        return cls(
            visible_db=calibration.get("visible_db", 10.0),
            n_harmonics=calibration.get("n_harmonics", 6),
            search_hz=search_hz,
            clutter_span_hz=fidelity["clutter_span_hz"],
            max_lag_cpis=fidelity["max_lag_cpis"],
        )


@dataclass
class CpiFeatures:
    """Per-CPI features of one record (see the module doc).

    Attributes
    ----------
    time_s : ndarray [n_t]
        CPI centres [s].
    line_hz : ndarray [n_harmonics, n_t]
        Body-relative HERM-line frequency per harmonic [Hz] (NaN outside the spectrogram).
    pair_db : ndarray [n_harmonics, n_t]
        SNR of each sideband pair, stronger side [dB] (-inf outside the spectrogram).
    n_pairs : ndarray, int [n_t]
    first_pair_db, asymmetry_db, blade_db, body_db, floor_db : ndarray [n_t]
        [dB]; NaN where not measurable.
    hop_s : float
        Time between CPIs [s].
    nonmultiple_pow, nonmultiple_ref, nonmultiple_var : ndarray [n_t], optional
        Per CPI, the summed power of the rotation-rate lines at non-multiples of the
        blade count, their blade-passing reference and the summed power's noise
        variance (:func:`rotation_line_sums`; 0 where none is measured); None when
        per-motor rates were not given.
    body_in_notch : bool
        The body line lies in the clutter notch at every CPI (:func:`body_in_notch`):
        ``body_db`` and ``first_pair_db`` (read on it) are NaN, the lines are placed
        about the given body Doppler.
    """

    time_s: np.ndarray
    line_hz: np.ndarray
    pair_db: np.ndarray
    n_pairs: np.ndarray
    first_pair_db: np.ndarray
    asymmetry_db: np.ndarray
    blade_db: np.ndarray
    body_db: np.ndarray
    floor_db: np.ndarray
    hop_s: float
    nonmultiple_pow: np.ndarray | None = None
    nonmultiple_ref: np.ndarray | None = None
    nonmultiple_var: np.ndarray | None = None
    body_in_notch: bool = False


def _finite(x) -> np.ndarray:
    x = np.asarray(x, float)
    return np.where(np.isfinite(x), x, np.nan)


def cpi_features(
    spec: Spectrogram,
    body_hz,
    rotor_rev_s,
    *,
    n_blades: int,
    half_spread_rev_s: float = 0.0,
    highpass_hz: float = 15.0,
    cfg: FidelityConfig = FidelityConfig(),
    motor_rev_s=None,
    line_power=None,
    window=None,
) -> CpiFeatures:
    """Per-CPI features of a spectrogram.

    Parameters
    ----------
    spec : Spectrogram
        The paper's spectrogram of the record.
    body_hz : ndarray [n_t]
        Expected body Doppler [Hz].
    rotor_rev_s : ndarray [n_t]
        Mean rotor rate [rev/s] placing the HERM windows.
    half_spread_rev_s : float
        Half-spread of the motors' rates [rev/s] (widens the sideband windows).
    highpass_hz : float
        The spectrogram's high-pass edge [Hz]; the clutter floor is read beyond it.
    motor_rev_s : ndarray [n_t, n_motors], optional
        Each motor's rate [rev/s]; with ``line_power`` and ``window``, the
        rotation-rate lines are measured (:func:`rotation_line_sums`).
    line_power : ndarray [rotation_orders + 1], optional
        One blade's own line power per rotation harmonic
        (``diagnosis.measure.thin_wire_line_power``).
    window : ndarray [n_fft], optional
        The spectrogram's analysis window.
    """
    body_hz = np.asarray(body_hz, float)
    h_hz = n_blades * np.asarray(rotor_rev_s, float)
    lines = measure_lines(
        spec,
        body_hz,
        rotor_rev_s,
        n_blades=n_blades,
        rotor_half_spread_rev_s=half_spread_rev_s,
        n_harmonics=cfg.n_harmonics,
        search_hz=cfg.search_hz,
    )
    pair = lines.pair_db
    n_pairs = np.cumprod(pair >= cfg.visible_db, axis=0).sum(axis=0)
    # line frequencies: power centroid of the stronger side's visible bins, relative to
    # the refined body peak
    st = Stft(10.0 ** (spec.power_db.astype(np.float64) / 10), spec.time_s, spec.doppler_hz, np.empty(0))
    f_body = refine_peak(st, body_hz, cfg.search_hz)
    notched = body_in_notch(f_body, highpass_hz=highpass_hz, search_hz=cfg.search_hz)
    if notched:
        # a hovering or stand-mounted body: its line is high-passed away, the rotor
        # lines stay symmetric about the known body Doppler
        f_body = np.where(np.abs(body_hz) <= highpass_hz + cfg.search_hz, body_hz, f_body)
    snr_db = spec.power_db - noise_floor_db(spec)[:, None]
    line_hz = np.full(pair.shape, np.nan)
    for k in range(1, cfg.n_harmonics + 1):
        sign = np.where(lines.upper_db[k - 1] >= lines.lower_db[k - 1], 1.0, -1.0)
        centre = herm_line_hz(f_body, h_hz, k, sign)
        w = (np.abs(spec.doppler_hz[None, :] - centre[:, None]) <= 0.45 * h_hz[:, None]) & (snr_db >= cfg.visible_db)
        p = np.where(w, st.p, 0.0)
        with np.errstate(invalid="ignore"):
            f_line = (p @ spec.doppler_hz) / p.sum(axis=1)
        line_hz[k - 1] = np.where(np.isfinite(pair[k - 1]) & w.any(axis=1), np.abs(f_line - f_body), np.nan)
    # floor next to the clutter line, the target's lines excluded
    f = spec.doppler_hz[None, :]
    near = (np.abs(f) > highpass_hz) & (np.abs(f) <= highpass_hz + cfg.clutter_span_hz)
    near = near & (np.abs(f - body_hz[:, None]) > cfg.search_hz)  # [n_t, n_bins]
    for k in range(1, cfg.n_harmonics + 1):
        for sign in (1, -1):
            near &= np.abs(f - herm_line_hz(body_hz, h_hz, k, sign)[:, None]) > cfg.search_hz
    floor = np.full(len(spec.time_s), np.nan)
    has = near.any(axis=1)
    floor[has] = np.nanmedian(np.where(near, spec.power_db, np.nan)[has], axis=1)
    hop_s = float(np.median(np.diff(spec.time_s))) if len(spec.time_s) > 1 else float("nan")
    nm = (None, None, None)
    if motor_rev_s is not None and line_power is not None and window is not None:
        st_w = Stft(st.p, st.t_s, st.f_hz, np.asarray(window, float))
        nm = rotation_line_sums(
            st_w,
            f_body,
            motor_rev_s,
            n_blades=n_blades,
            line_power=line_power,
            highpass_hz=highpass_hz,
            cfg=cfg,
            notched=notched,
        )
    body_db = np.full(len(spec.time_s), np.nan) if notched else lines.body_db  # no body line to read
    return CpiFeatures(
        spec.time_s,
        line_hz,
        pair,
        n_pairs,
        _finite(pair[0] - body_db),
        _finite(lines.upper_db[0] - lines.lower_db[0]),
        _finite(pair[0]),
        _finite(body_db),
        floor - noise_floor_db(spec),
        hop_s,
        *nm,
        body_in_notch=notched,
    )


def line_dilation(
    st: Stft,
    f_body_hz,
    motor_rev_s,
    valid,
    *,
    n_blades: int,
    max_rel: float,
    smooth_cpis: int | None = None,
    step: float | None = None,
) -> np.ndarray:
    """Per CPI the factor s (within 1 +- ``max_rel``, on a grid of ``step``) by which
    the rotors' lines sit off their given rates: the s whose blade-passing lines
    (orders B and 2B of every rotor, both sides, +-1 bin) hold the most power, then a
    running median over ``smooth_cpis`` CPIs of those where the lines stand above the
    floor (others get the median of the flight; 1 when there is none). A log's scale
    error or lag moves every rotor's lines by about the same factor. ``smooth_cpis``
    and ``step`` default to :class:`FidelityConfig`'s ``dilation_smooth_cpis`` and
    ``dilation_step``."""
    smooth_cpis = FidelityConfig().dilation_smooth_cpis if smooth_cpis is None else smooth_cpis
    step = FidelityConfig().dilation_step if step is None else step
    n_t = len(st.t_s)
    out = np.full(n_t, np.nan)
    if max_rel <= 0:
        return np.ones(n_t)
    grid = np.arange(1 - max_rel, 1 + max_rel + step / 2, step)
    orders = n_blades * np.array([1.0, 2.0])
    n_bins = st.p.shape[1]
    for i in np.flatnonzero(valid):
        fr = np.asarray(motor_rev_s[i], float)
        if not np.all(np.isfinite(fr)) or np.any(fr <= 0):
            continue
        f = (
            f_body_hz[i]
            + np.array([1.0, -1.0])[None, :, None, None]
            * grid[:, None, None, None]
            * orders[None, None, :, None]
            * fr[None, None, None, :]
        )  # [n_s, side, order, motor]
        b = np.rint(st.at(f)).astype(int)
        inside = (b >= 1) & (b < n_bins - 1)
        bc = np.clip(b, 1, n_bins - 2)
        pw = (st.p[i, bc - 1] + st.p[i, bc] + st.p[i, bc + 1]) * inside
        score = pw.reshape(len(grid), -1).sum(axis=1)
        floor = float(np.median(st.p[i])) / np.log(2.0)
        n_cells = 3 * max(int(inside.reshape(len(grid), -1).sum(axis=1).max()), 1)
        if score.max() > 2.0 * n_cells * floor:  # the lines hold at least the noise's power again
            out[i] = grid[int(np.argmax(score))]
    ok = np.isfinite(out)
    if not ok.any():
        return np.ones(n_t)
    fill = float(np.median(out[ok]))
    h = max(int(smooth_cpis) // 2, 0)
    sm = np.array(
        [
            np.nanmedian(out[max(0, i - h) : i + h + 1]) if np.isfinite(out[max(0, i - h) : i + h + 1]).any() else fill
            for i in range(n_t)
        ]
    )
    return sm


def body_in_notch(f_body_hz, *, highpass_hz: float, search_hz: float) -> bool:
    """True when no CPI's body line (``f_body_hz`` [n_t], Hz) lies beyond the clutter
    notch (``highpass_hz`` + ``search_hz``): a hovering or stand-mounted drone, whose
    features are measured about the known body Doppler instead of its line's peak."""
    f = np.asarray(f_body_hz, float)
    return not bool(np.any(np.isfinite(f) & (np.abs(f) > highpass_hz + search_hz)))


def rotation_line_sums(
    st: Stft,
    f_body_hz,
    motor_rev_s,
    *,
    n_blades: int,
    line_power,
    highpass_hz: float,
    cfg: FidelityConfig = FidelityConfig(),
    notched: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per CPI, the summed power of the rotation-rate lines at non-multiples of the
    blade count, of their blade-passing reference (module doc) and the summed power's
    noise variance (kappa (n_b fl^2 + 2 P fl) per line, ``rotation_line_powers``):
    float [n_t] each, 0 where nothing is measured. ``st`` is the spectrogram as a power periodogram with its
    analysis window; ``f_body_hz`` [n_t] the body line; ``motor_rev_s`` [n_t, n_motors]
    each motor's rate; ``line_power`` [cfg.rotation_orders + 1] one blade's own line
    power per order.

    The CPIs measured are those whose body line lies beyond the clutter notch
    (``highpass_hz`` + ``cfg.search_hz``); with ``notched`` (:func:`body_in_notch`:
    no CPI has its body there, a hovering or stand-mounted drone), those whose body
    Doppler ``f_body_hz`` (then the track's) lies within it: the rotor lines about it
    are clear of the notch where each line's own check (``rotation_line_powers``) says so."""
    rev = np.asarray(motor_rev_s, float)
    n_t, n_m = rev.shape
    if len(line_power) < cfg.rotation_orders + 1:
        raise ValueError(f"line_power has {len(line_power)} orders, expected {cfg.rotation_orders + 1}")
    f_body_hz = np.asarray(f_body_hz, float)
    beyond = np.abs(f_body_hz) > highpass_hz + cfg.search_hz
    valid = (
        np.isfinite(f_body_hz)
        & np.all(np.isfinite(rev), axis=1)
        & np.all(rev > 0, axis=1)
        & (~beyond if notched else beyond)
    )
    floor = np.median(st.p, axis=1) / np.log(2.0)
    s = line_dilation(
        st,
        f_body_hz,
        rev,
        valid,
        n_blades=n_blades,
        max_rel=cfg.dilation_range,
        smooth_cpis=cfg.dilation_smooth_cpis,
        step=cfg.dilation_step,
    )
    P, V, W, R = rotation_line_powers(
        st,
        f_body_hz,
        rev * s[:, None],
        valid,
        n_blades,
        cfg.rotation_orders,
        floor,
        clutter_guard_hz=highpass_hz,
        raised_floor_db=DiagnosisConfig().raised_floor_db,  # the diagnosis's sideband guard, as it fixes it
    )
    x, v0, w, ref, idx = non_multiple_observations(
        P, V, W, R, np.asarray(line_power, float), n_blades, n_m, min_z=cfg.nonmultiple_min_z
    )
    var = v0 + w * np.clip(x, 0, None)
    return (
        np.bincount(idx, x, minlength=n_t),
        np.bincount(idx, ref, minlength=n_t),
        np.bincount(idx, var, minlength=n_t),
    )


def nonmultiple_db(f: CpiFeatures, mask, cfg: FidelityConfig = FidelityConfig()) -> float:
    """``nonmultiple_db`` over the CPIs in ``mask``: 10 log10(sum of the non-multiple
    lines' power / sum of their blade-passing reference), floored at
    ``cfg.nonmultiple_floor_db``, and the floor where the summed power is below
    ``cfg.nonmultiple_z`` times its noise standard deviation; NaN with the reference
    in fewer than ``cfg.nonmultiple_min_cpis`` CPIs."""
    if f.nonmultiple_pow is None:
        return float("nan")
    mask = np.asarray(mask, bool)
    ref = float(np.sum(f.nonmultiple_ref[mask]))
    if not ref > 0 or int(np.sum(f.nonmultiple_ref[mask] > 0)) < cfg.nonmultiple_min_cpis:
        return float("nan")
    x = float(np.sum(f.nonmultiple_pow[mask]))
    sd = float(np.sqrt(np.sum(f.nonmultiple_var[mask]))) if f.nonmultiple_var is not None else 0.0
    if not x > cfg.nonmultiple_z * sd:
        return float(cfg.nonmultiple_floor_db)
    return float(max(10 * np.log10(x / ref), cfg.nonmultiple_floor_db))


def flight_features(
    flight, iq, motor_log, *, spec_cfg: SpectrogramConfig, cfg: FidelityConfig = FidelityConfig()
) -> CpiFeatures:
    """Features of ``iq`` (the flight's own or its injected twin) with the flight's
    track and motor log placing the lines (as ``fit_twin`` measures its targets)."""
    spec = spectrogram(iq, flight.prf_hz, spec_cfg)
    body = body_doppler_hz(flight.track_time_s, flight.track_radial_velocity_mps, flight.wavelength_m, spec.time_s)
    rate, spread = log_rate_at(motor_log.time_s, motor_log.rev_s, spec.time_s)
    t = np.asarray(spec.time_s, float)
    motors = np.column_stack(
        [np.interp(t, motor_log.time_s, motor_log.rev_s[:, m]) for m in range(motor_log.rev_s.shape[1])]
    )
    wire = thin_wire_line_power(float(flight.attrs["blade_length_m"]), flight.wavelength_m, cfg.rotation_orders)
    return cpi_features(
        spec,
        body,
        rate,
        n_blades=int(flight.attrs["n_blades"]),
        half_spread_rev_s=float(np.percentile(spread, 90)),
        highpass_hz=spec_cfg.highpass_hz,
        cfg=cfg,
        motor_rev_s=motors,
        line_power=wire,
        window=window(spec_cfg.n_fft),
    )


def correlation_timescale_s(x, mask, hop_s: float, max_lag: int) -> float:
    """1/e time of the autocorrelation of ``x`` [n_t] over the CPIs in ``mask`` [s].

    Lag L uses the pairs (i, i + L) both in ``mask`` (held-out blocks are not
    contiguous); the crossing is interpolated linearly; ``max_lag * hop_s`` when the
    autocorrelation stays above 1/e (censored); NaN with fewer than 3 values."""
    x = np.asarray(x, float)
    ok = np.asarray(mask, bool) & np.isfinite(x)
    if ok.sum() < 3:
        return float("nan")
    y = np.where(ok, x - x[ok].mean(), 0.0)
    var = float(np.mean(y[ok] ** 2))
    if var <= 0:
        return float("nan")
    r_prev, lag_prev = 1.0, 0
    for lag in range(1, min(max_lag, len(x) - 1) + 1):
        both = ok[:-lag] & ok[lag:]
        if not both.any():
            continue
        r = float(np.mean((y[:-lag] * y[lag:])[both])) / var
        if r < np.exp(-1):
            return hop_s * (lag_prev + (r_prev - np.exp(-1)) / (r_prev - r) * (lag - lag_prev))
        r_prev, lag_prev = r, lag
    return hop_s * max_lag


def _mean(x, mask) -> float:
    x = np.asarray(x, float)[mask]
    x = x[np.isfinite(x)]
    return float(np.mean(x)) if x.size else float("nan")


def _std(x, mask) -> float:
    x = np.asarray(x, float)[mask]
    x = x[np.isfinite(x)]
    return float(np.std(x, ddof=1)) if x.size > 1 else float("nan")


def summarise(f: CpiFeatures, mask, cfg: FidelityConfig = FidelityConfig()) -> dict:
    """Flight-level statistics over the CPIs in ``mask`` (bool [n_t]): mean visible
    pairs, first-pair level, asymmetry and floor, std of blade and body SNR, the
    blade fading timescale [s], the non-multiple rotation lines' level (:func:`nonmultiple_db`)."""
    mask = np.asarray(mask, bool)
    return {
        "n_pairs": _mean(f.n_pairs, mask),
        "first_pair_db": _mean(f.first_pair_db, mask),
        "asymmetry_db": _mean(f.asymmetry_db, mask),
        "blade_std_db": _std(f.blade_db, mask),
        "blade_timescale_s": correlation_timescale_s(f.blade_db, mask, f.hop_s, cfg.max_lag_cpis),
        "body_std_db": _std(f.body_db, mask),
        "floor_db": _mean(f.floor_db, mask),
        "nonmultiple_db": nonmultiple_db(f, mask, cfg),
    }


def distances(measured: CpiFeatures, twin: CpiFeatures, mask, cfg: FidelityConfig = FidelityConfig()) -> dict:
    """Per-feature distance twin vs measured flight over the CPIs in ``mask`` (the
    keys of :data:`DISTANCES`; see the module doc)."""
    mask = np.asarray(mask, bool)
    if measured.line_hz.shape != twin.line_hz.shape:
        raise ValueError(f"measured and twin have {measured.line_hz.shape} and {twin.line_hz.shape} lines x CPIs")
    med = np.array(
        [np.median(r[np.isfinite(r)]) if np.isfinite(r).any() else -np.inf for r in measured.pair_db[:, mask]]
    )
    vis = np.flatnonzero(np.cumprod(med >= cfg.visible_db))
    ks = vis if vis.size else np.array([0])
    d = np.abs(twin.line_hz[ks][:, mask] - measured.line_hz[ks][:, mask])
    out = {"line_hz": float(np.mean(d[np.isfinite(d)])) if np.isfinite(d).any() else float("nan")}
    a, b = summarise(measured, mask, cfg), summarise(twin, mask, cfg)
    out.update({k: abs(b[k] - a[k]) for k in a})
    return {k: out[k] for k in DISTANCES}


def scoring_mask(calibration: dict, n_t: int) -> tuple[np.ndarray, bool]:
    """CPIs the calibration did not see, from a twin's ``calibration`` attrs: (bool
    [n_t], held_out). Without a held-out fold recorded, every CPI (held_out False)."""
    if calibration.get("fit_cpis") is not None:
        mask = ~np.isin(np.arange(n_t), np.asarray(calibration["fit_cpis"], int))
    elif int(calibration.get("holdout_block_cpis") or 0) > 0:
        mask = folds(n_t, int(calibration["holdout_block_cpis"])) == 1
    else:
        return np.ones(n_t, bool), False
    return mask, bool(mask.any())


#: schema of the measured flights' features (:func:`measure_flights`)
FEATURES_SCHEMA = "fidelity-features/1"
#: the per-CPI arrays of :class:`CpiFeatures` (the optional ones stored where measured)
_FEATURE_ARRAYS = (
    "time_s",
    "line_hz",
    "pair_db",
    "n_pairs",
    "first_pair_db",
    "asymmetry_db",
    "blade_db",
    "body_db",
    "floor_db",
    "nonmultiple_pow",
    "nonmultiple_ref",
    "nonmultiple_var",
)


def measured_flight_ids(measured_dir, logs_zarr) -> list[str]:
    """The flights a twin can be made of and scored against: drone flights of a
    twinned model (:func:`.split.twin_model`) with a background recording and an
    ingested motor log."""
    flights = list_flights(measured_dir)
    drones = flights[(flights.target == "drone") & flights.has_background]
    if not Path(logs_zarr).exists():
        return []
    return [
        fid
        for fid, model in zip(drones.flight_id, drones.drone_model)
        if twin_model(model) and read_ingested_log(logs_zarr, fid) is not None
    ]


def measure_flights(
    measured_dir,
    logs_zarr,
    out,
    *,
    spec_cfg: SpectrogramConfig,
    cfg: FidelityConfig = FidelityConfig(),
    log=print,
) -> list[str]:
    """Measure once the features of every flight a twin is scored against
    (:func:`measured_flight_ids`) and write them to the Zarr store ``out``
    (``fidelity-features/1``: a group per flight, the :class:`CpiFeatures` arrays,
    ``hop_s`` and ``body_in_notch`` in its attributes); every variant's
    :func:`score_variant` reads them there instead of measuring the flight again.
    Returns the flight ids written."""
    fids = measured_flight_ids(measured_dir, logs_zarr)
    with writing_store(out, {"schema": FEATURES_SCHEMA, "n_flights": len(fids)}) as root:
        for i, fid in enumerate(fids):
            flight = read_flight(Path(measured_dir) / f"{fid}.zarr")
            f = flight_features(flight, flight.iq, read_ingested_log(logs_zarr, fid), spec_cfg=spec_cfg, cfg=cfg)
            write_features(root.require_group(fid), f)
            log(f"{fid}: measured ({len(f.time_s)} CPIs; {i + 1} of {len(fids)})")
    return fids


def write_features(group, f: CpiFeatures) -> None:
    """Store ``f`` in the Zarr ``group`` (its arrays, ``hop_s`` and ``body_in_notch``
    in the attributes); :func:`read_features` gives it back unchanged."""
    group.attrs.update({"hop_s": float(f.hop_s), "body_in_notch": bool(f.body_in_notch)})
    for name in _FEATURE_ARRAYS:
        if getattr(f, name) is not None:
            put_array(group, name, np.asarray(getattr(f, name)))


def read_features(group) -> CpiFeatures:
    """The :class:`CpiFeatures` :func:`write_features` stored in ``group``."""
    arrays = {name: np.asarray(group[name][...]) if name in group else None for name in _FEATURE_ARRAYS}
    return CpiFeatures(**arrays, hop_s=float(group.attrs["hop_s"]), body_in_notch=bool(group.attrs["body_in_notch"]))


def read_measured_features(store) -> dict[str, CpiFeatures]:
    """flight_id -> :class:`CpiFeatures`, from a store written by :func:`measure_flights`."""
    root = open_store(store, FEATURES_SCHEMA)
    return {fid: read_features(root[fid]) for fid in flight_ids(root)}


def score_variant(
    measured_dir,
    logs_zarr,
    injected_zarr,
    variant: str,
    *,
    spec_cfg: SpectrogramConfig,
    cfg: FidelityConfig = FidelityConfig(),
    cache: dict | None = None,
    log=print,
) -> pd.DataFrame:
    """Distances of every injected twin of one variant to its measured flight.

    Returns one row per twin: flight_id, variant, drone_model, held_out, n_cpis_scored,
    extension_source, the :data:`DISTANCES`, ``lines_visible``
    (:func:`rotor_lines_visible`; where False, the :data:`ROTOR_LINE_DISTANCES` are
    NaN: there are no measured lines to compare with) and ``body_in_notch`` (the
    measured flight's, :class:`CpiFeatures`). ``cache`` (flight_id -> measured
    CpiFeatures, e.g. :func:`read_measured_features`) spares measuring the measured
    flights again; a flight missing from it is measured and added."""
    cache = {} if cache is None else cache
    root = open_store(injected_zarr, INJECTED_SCHEMA)
    rows = []
    for fid in flight_ids(root):
        g = root[fid]
        path = Path(measured_dir) / f"{fid}.zarr"
        flight = read_flight(path)
        ml = read_ingested_log(logs_zarr, fid)
        if ml is None:
            raise InputError(str(logs_zarr), f"{fid}/motors", "missing", "the motor log the twin was fitted with")
        if fid not in cache:
            cache[fid] = flight_features(flight, flight.iq, ml, spec_cfg=spec_cfg, cfg=cfg)
        twin = flight_features(flight, np.asarray(g["iq"][...]), ml, spec_cfg=spec_cfg, cfg=cfg)
        mask, held_out = scoring_mask(dict(g.attrs.get("calibration", {})), len(twin.time_s))
        d = distances(cache[fid], twin, mask, cfg)
        visible = rotor_lines_visible(cache[fid], mask)
        if not visible:
            d.update({k: float("nan") for k in ROTOR_LINE_DISTANCES})
        rows.append(
            {
                "flight_id": fid,
                "variant": variant,
                "drone_model": g.attrs.get("drone_model", ""),
                "held_out": held_out,
                "n_cpis_scored": int(mask.sum()),
                "extension_source": str(dict(g.attrs.get("extensions") or {}).get("source", "")),
                **d,
                "lines_visible": visible,
                "body_in_notch": bool(cache[fid].body_in_notch),
            }
        )
        log(
            f"{variant} {fid}: {int(mask.sum())} CPIs scored (held out: {held_out}) "
            + " ".join(f"{k}={v:.3g}" for k, v in d.items())
        )
    return pd.DataFrame(rows, columns=SCORE_COLUMNS)


#: columns of a variant's scores (:func:`score_variant`, :func:`write_scores`)
SCORE_COLUMNS = [
    "flight_id",
    "variant",
    "drone_model",
    "held_out",
    "n_cpis_scored",
    "extension_source",
    *DISTANCES,
    "lines_visible",
    "body_in_notch",
]


def write_scores(scores: pd.DataFrame, path) -> None:
    """Write one variant's :func:`score_variant` table (atomically), every float at
    full precision, so :func:`read_scores` gives back the same numbers."""
    with atomic_file(path) as tmp:
        scores.to_csv(tmp, index=False)


def read_scores(path) -> pd.DataFrame:
    """A table written by :func:`write_scores` (the same values and types)."""
    df = pd.read_csv(
        path,
        keep_default_na=False,
        na_values={c: ["", "NaN", "nan"] for c in DISTANCES},
        dtype={"flight_id": str, "variant": str, "drone_model": str, "extension_source": str},
    )
    missing = [c for c in SCORE_COLUMNS if c not in df.columns]
    if missing:
        raise InputError(path, ",".join(missing), "missing column", ", ".join(SCORE_COLUMNS))
    for c in ("held_out", "lines_visible", "body_in_notch"):
        df[c] = df[c].astype(str).str.lower().eq("true")
    df["n_cpis_scored"] = df["n_cpis_scored"].astype(int)
    for c in DISTANCES:
        df[c] = df[c].astype(float)
    return df[SCORE_COLUMNS]


#: the distances read on the body line (not measured on a body in the clutter notch)
BODY_LINE_DISTANCES = ("first_pair_db", "body_std_db")
#: the distances read on the rotor lines (not measured on a flight without visible lines)
ROTOR_LINE_DISTANCES = (
    "line_hz",
    "n_pairs",
    "first_pair_db",
    "asymmetry_db",
    "blade_std_db",
    "blade_timescale_s",
    "nonmultiple_db",
)


def rotor_lines_visible(measured: CpiFeatures, mask) -> bool:
    """Whether the measured flight shows its rotor lines: the first sideband pair
    visible (``n_pairs`` >= 1) in at least one of the CPIs in ``mask``."""
    mask = np.asarray(mask, bool)
    return bool(np.any(np.asarray(measured.n_pairs)[mask] >= 1))


def _order(variants) -> list[str]:
    variants = list(dict.fromkeys(variants))
    order = ORDER + ("extended",)
    return [v for v in order if v in variants] + sorted(v for v in variants if v not in order)


def fidelity_table(per_flight: pd.DataFrame, *, n_boot: int = N_BOOT, seed: int = 0) -> pd.DataFrame:
    """Table VI from the per-flight distances (:func:`score_variant` rows).

    One row per variant: ``n_flights`` and per distance m ``m_mean`` (mean over the
    flights where it is finite) and ``m_ci95_low``/``m_ci95_high`` (95 % percentile
    interval, flights drawn with replacement, :mod:`microdoppler.stats.bootstrap`). Then
    paired rows ``a - b`` (adjacent orderings of :data:`PAIRS` present): per flight
    the difference of the two twins' distances (negative = a closer to the
    measurement) of :func:`pairs`, its mean, interval from the same draws, and
    ``m_resolved`` (the interval excludes 0).

    Where the ``extended`` twins' extensions came from more than one source (column
    ``extension_source``: ``own`` = their own flight's diagnosed causes, ``population``
    = drawn per drone model for flights the diagnosis did not cover, ``skipped`` =
    none), rows ``extended [<source>] - sub_cpi`` give the paired difference over the
    flights of each source (same draws): the gain of carrying a flight's own
    discrepancies is the ``own`` row, not the mixture.
    """
    cols = ["variant", "n_flights"] + [
        f"{m}_{s}" for m in DISTANCES for s in ("mean", "ci95_low", "ci95_high", "resolved")
    ]
    variants = _order(per_flight["variant"])
    flights = sorted(per_flight["flight_id"].unique())
    if not flights:
        return pd.DataFrame(columns=cols)
    draws = draw_flights(flights, n_boot=n_boot, seed=seed)
    table = {v: per_flight[per_flight["variant"] == v].set_index("flight_id").reindex(flights) for v in variants}

    def stats(values: np.ndarray) -> tuple[float, float, float, int]:
        ok = np.isfinite(values)
        if not ok.any():
            return float("nan"), float("nan"), float("nan"), 0
        lo, hi = interval(ratio_replicates(np.where(ok, values, 0.0), ok.astype(float), draws))
        return float(values[ok].mean()), lo, hi, int(ok.sum())

    rows = []
    for v in variants:
        row = {"variant": v, "n_flights": int(table[v]["variant"].notna().sum())}
        for m in DISTANCES:
            row[f"{m}_mean"], row[f"{m}_ci95_low"], row[f"{m}_ci95_high"], _ = stats(table[v][m].to_numpy(float))
        rows.append(row)
    for a, b in pairs(variants):
        row = {"variant": f"{a} - {b}"}
        for m in DISTANCES:
            mean, lo, hi, n = stats(table[a][m].to_numpy(float) - table[b][m].to_numpy(float))
            row.update(
                {f"{m}_mean": mean, f"{m}_ci95_low": lo, f"{m}_ci95_high": hi, f"{m}_resolved": resolved(lo, hi)}
            )
            row["n_flights"] = max(row.get("n_flights", 0), n)
        rows.append(row)
    for src, keep in _extension_sources(per_flight, flights):
        row = {"variant": f"extended [{src}] - sub_cpi"}
        for m in DISTANCES:
            diff = table["extended"][m].to_numpy(float) - table["sub_cpi"][m].to_numpy(float)
            mean, lo, hi, n = stats(np.where(keep, diff, np.nan))
            row.update(
                {f"{m}_mean": mean, f"{m}_ci95_low": lo, f"{m}_ci95_high": hi, f"{m}_resolved": resolved(lo, hi)}
            )
            row["n_flights"] = max(row.get("n_flights", 0), n)
        rows.append(row)
    return pd.DataFrame(rows).reindex(columns=cols)


def _extension_sources(per_flight: pd.DataFrame, flights: list) -> list[tuple[str, np.ndarray]]:
    """(source, bool mask over ``flights``) of the extended twins, when they come from
    two or more sources and sub_cpi twins exist; else []."""
    if "extension_source" not in per_flight.columns or not {"extended", "sub_cpi"} <= set(per_flight["variant"]):
        return []
    ext = per_flight[per_flight["variant"] == "extended"].set_index("flight_id")["extension_source"]
    src = ext.reindex(flights).fillna("").astype(str).to_numpy()
    names = [s for s in dict.fromkeys(src) if s]
    if len(names) < 2:
        return []
    order = {"own": 0, "population": 1, "skipped": 2}
    return [(s, src == s) for s in sorted(names, key=lambda s: (order.get(s, 9), s))]


#: columns of the flights Table VI leaves out (``results/reports/fidelity_left_out.csv``)
LEFT_OUT_COLUMNS = ["flight_id", "drone_model", "variants", "reason"]


def _ingest_reasons(logs_zarr) -> dict[str, str]:
    """flight_id -> why the motor-log ingest skipped it (``ingest.csv`` beside the logs)."""
    path = Path(logs_zarr).parent / "ingest.csv"
    if not path.exists():
        return {}
    df = pd.read_csv(path, dtype={"flight_id": str}, keep_default_na=False)
    if "reason" not in df.columns:
        return {}
    return {r.flight_id: str(r.reason) for r in df.itertuples() if str(r.reason)}


def left_out_flights(
    measured_dir, logs_zarr, injected: dict, per_flight: pd.DataFrame, *, cfg: FidelityConfig = FidelityConfig()
) -> pd.DataFrame:
    """The drone flights that Table VI does not score, with the reason (one row per
    flight and reason; ``variants``: the variants it applies to, space-separated).

    Reasons: no twins are made of the flight's drone model (:func:`.split.twin_model`);
    no motor log; no background recording to inject a twin into; no twin in the
    variant's store; no held-out CPI; no feature measurable on the held-out CPIs. A
    flight scored without visible rotor lines (``lines_visible`` False) is named too:
    its rotor-line features are left out, the others scored; so is a flight whose body
    line sits in the clutter notch (``body_in_notch``): its body-line features are left
    out."""
    flights = list_flights(measured_dir)
    drones = flights[flights.target == "drone"]
    ingest = _ingest_reasons(logs_zarr)
    logged = set()
    if Path(logs_zarr).exists():
        logged = {fid for fid in drones.flight_id if read_ingested_log(logs_zarr, fid) is not None}
    scored = per_flight.set_index(["flight_id", "variant"]) if len(per_flight) else None
    stores = {v: set(flight_ids(open_store(path, INJECTED_SCHEMA))) for v, path in injected.items()}
    reasons: dict[tuple[str, str], list[str]] = {}
    for fl in drones.itertuples():
        for v in injected:
            if not twin_model(fl.drone_model):
                why = (
                    f"no twins of drone model {fl.drone_model or '(none)'!r}: twins are made of "
                    f"{', '.join(TWIN_MODELS)} and of drone models the catalog does not hold"
                )
            elif fl.flight_id not in logged:
                why = ingest.get(fl.flight_id) or "no motor log (not in the ingested logs)"
            elif not fl.has_background:
                why = "no background recording (background/iq): no twin can be injected"
            elif fl.flight_id not in stores[v]:
                why = f"no twin in the {v} store"
            else:
                key = (fl.flight_id, v)
                row = scored.loc[key] if scored is not None and key in scored.index else None
                if row is None or int(row["n_cpis_scored"]) == 0:
                    why = "no held-out CPI to score (the calibration fitted every CPI)"
                elif not np.isfinite(row[list(DISTANCES)].to_numpy(float)).any():
                    why = "no feature measurable on the held-out CPIs"
                else:
                    parts = []
                    if "lines_visible" in row.index and not bool(row["lines_visible"]):
                        parts.append(
                            f"rotor lines not visible on the held-out CPIs (first sideband pair below "
                            f"{cfg.visible_db:g} dB in all {int(row['n_cpis_scored'])}): its rotor-line "
                            f"features ({', '.join(ROTOR_LINE_DISTANCES)}) are left out, the others scored"
                        )
                    if "body_in_notch" in row.index and bool(row["body_in_notch"]):
                        parts.append(
                            "body line in the clutter notch (hovering or stand-mounted): its body-line "
                            f"features ({', '.join(BODY_LINE_DISTANCES)}) are left out, the rotor lines "
                            "scored about the track's body Doppler"
                        )
                    if not parts:
                        continue
                    why = "; ".join(parts)
            reasons.setdefault((fl.flight_id, fl.drone_model, why), []).append(v)
    rows = [
        {"flight_id": fid, "drone_model": model, "variants": " ".join(vs), "reason": why}
        for (fid, model, why), vs in reasons.items()
    ]
    return pd.DataFrame(rows, columns=LEFT_OUT_COLUMNS)


def _note_panel(ax, lines: list[str]) -> None:
    ax.set_axis_off()
    ax.text(
        0.02,
        0.98,
        "\n".join(lines),
        va="top",
        ha="left",
        fontsize=9,
        family="monospace",
        transform=ax.transAxes,
        wrap=True,
    )


def plot_fidelity(table: pd.DataFrame, path, *, left_out: pd.DataFrame | None = None) -> None:
    """Per distance, the mean and 95 % interval of every variant (Table VI's first rows).

    Never an empty panel: with no variant scored, one panel says why (the flights
    ``left_out``, :func:`left_out_flights`); a distance no flight has is a panel that
    says so."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = table[~table["variant"].str.contains(" - ")]
    if t.empty:
        fig, ax = plt.subplots(figsize=(9.0, 4.0))
        lines = ["Table VI could not be formed: no drone flight has a twin scored on held-out CPIs."]
        if left_out is not None and len(left_out):
            lines += ["", "Flights left out:"]
            shown = left_out.head(12)
            lines += [f"  {r.flight_id}: {r.reason}" for r in shown.itertuples()]
            if len(left_out) > len(shown):
                lines.append(f"  ... and {len(left_out) - len(shown)} more (fidelity_left_out.csv)")
        else:
            lines.append("The campaign holds no drone flight.")
        _note_panel(ax, lines)
        with atomic_file(path) as tmp:
            fig.savefig(tmp, dpi=110)
        plt.close(fig)
        return
    n_col = int(np.ceil(len(DISTANCES) / 2))
    fig, axes = plt.subplots(2, n_col, figsize=(3.25 * n_col, 5.5), squeeze=False)
    x = np.arange(len(t))
    for ax, (m, unit) in zip(axes.ravel(), DISTANCES.items()):
        mean = t[f"{m}_mean"].to_numpy(float)
        if not np.isfinite(mean).any():
            ax.set_title(f"|Δ {m}| [{unit}]", fontsize=9)
            _note_panel(ax, ["no flight has", f"{m} measured", "on held-out CPIs"])
            continue
        err = np.abs(np.vstack([mean - t[f"{m}_ci95_low"].to_numpy(float), t[f"{m}_ci95_high"].to_numpy(float) - mean]))
        ax.errorbar(x, mean, yerr=np.nan_to_num(err), fmt="o", color="black", capsize=3)
        ax.set_xticks(x, t["variant"], rotation=30, fontsize=8)
        ax.set_xlim(-0.5, len(t) - 0.5)
        ax.set_title(f"|Δ {m}| [{unit}]", fontsize=9)
        ax.grid(axis="y", alpha=0.3)
    for ax in axes.ravel()[len(DISTANCES) :]:
        ax.set_visible(False)
    fig.suptitle("Twin vs measured flight on held-out CPIs: mean distance over flights, 95 % flight bootstrap")
    fig.tight_layout()
    with atomic_file(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def write_fidelity_report(
    measured_dir,
    logs_zarr,
    injected: dict,
    table_csv,
    figure_png,
    flights_csv,
    *,
    spec_cfg: SpectrogramConfig,
    cfg: FidelityConfig = FidelityConfig(),
    n_boot: int = N_BOOT,
    seed: int = 0,
    left_out_csv=None,
    scores: dict | None = None,
    log=print,
) -> pd.DataFrame:
    """Score every variant's injected twins (``injected``: variant -> store), write the
    per-flight distances, Table VI and its figure; returns Table VI.

    ``scores`` (variant -> its :func:`score_variant` table, as the pipeline's rule
    ``score_twins`` writes them per variant) are used as given instead of scoring
    the variant here. The drone flights left out (:func:`left_out_flights`) are
    logged one line each with the reason and written to ``left_out_csv``; a Table VI
    without rows is logged with why, and its figure is a panel that says so."""
    cache: dict = {}
    scores = dict(scores or {})
    per_flight = pd.concat(
        [
            scores[v]
            if v in scores
            else score_variant(measured_dir, logs_zarr, path, v, spec_cfg=spec_cfg, cfg=cfg, cache=cache, log=log)
            for v, path in injected.items()
        ],
        ignore_index=True,
    )
    table = fidelity_table(per_flight, n_boot=n_boot, seed=seed)
    left = left_out_flights(measured_dir, logs_zarr, injected, per_flight, cfg=cfg)
    for r in left.itertuples():
        log(f"{r.flight_id}: left out of Table VI ({r.variants}): {r.reason}")
    if table.empty:
        log(
            f"Table VI has no rows: no drone flight has a twin scored on held-out CPIs "
            f"({left.flight_id.nunique()} drone flights left out, reasons above)"
        )
    elif len(per_flight):
        for m in DISTANCES:
            if not np.isfinite(per_flight[m].to_numpy(float)).any():
                log(f"Table VI: {m} was measured on no flight's held-out CPIs (its columns are empty)")
    flights = per_flight.drop(columns=["lines_visible", "body_in_notch"], errors="ignore")
    outputs = [(flights, flights_csv), (table, table_csv)] + ([(left, left_out_csv)] if left_out_csv else [])
    for df, path in outputs:
        with atomic_file(path) as tmp:
            df.to_csv(tmp, index=False, float_format="%.6g")
    plot_fidelity(table, figure_png, left_out=left)
    return table
