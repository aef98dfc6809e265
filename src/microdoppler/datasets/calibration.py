"""Stage ``synthesize_flights``: each measured Inspire/Matrice flight's synthetic twin,
calibrated per flight as the paper does (§V.B, Table IV).

The twin is eq. (2) (``synthesis.synthesize``) driven by the flight's own resampled
motor speeds and its own track, injected into the flight's ``background/iq`` and
measured with the same spectrogram chain and the one SNR measure (``lines``):

1. alpha [s] matches the measured number of visible sideband pairs (median SNR of a
   pair >= ``visible_db``). Alphas whose scaling fit (step 2) reaches the tolerance
   come first (the blade's mean over a revolution lies on the body line, so a blade
   scaled up to beat a strong alpha can swamp the body); among them the count must
   match, and among equal counts the harmonic SNR profile (pairs 2..n) closest to
   the measured one wins. alpha is
   searched on a log grid in [alpha_min_s, alpha_max_s] (plus 0).
2. For each alpha, S_blade is set so that the first sideband pair's flight-mean SNR
   matches and S_body so that the body's does. The echo is linear in S_body and
   S_blade (x = S_body b + S_blade m + background), and so is the spectrogram chain
   up to the squared magnitude (high-pass, STFT), so the search forms the complex
   STFT of each component once and combines them (S_body B + S_blade M + G) instead
   of re-synthesising or re-transforming; each step is a multiplicative update by the
   dB error (fixed point), repeated until both errors are below a quarter of the
   tolerance or ``max_iter`` steps (at the chosen alpha: a sixteenth,
   ``final_tol_fraction``; the fixed settings are ``config=False`` fields of
   :class:`CalibrationConfig`).
   The blade's mean over a revolution (its zero-Doppler term, which sits on the
   body line) is removed by default (``remove_blade_mean``), so S_body alone sets
   the body line.
3. The twin is then synthesised once more from scratch with the fitted Scaling,
   injected and measured on every fit CPI: the achieved errors are recorded and a
   flight that misses ``tolerance_db`` (2 dB) on the body or first sideband is
   flagged ``missed``.

Cost: the alpha search (steps 1-2 for every alpha) reads at most ``max_fit_cpis``
of the fit CPIs (fold A), in short runs spread evenly over the flight; the body and
blade components are synthesised and high-passed only around those CPIs
(``highpass_margin_pulses`` either side), so the search costs the same for any flight
duration. Its best ``alpha_recheck`` alphas are then ranked again with step 2 on
every fit CPI (whole body and blade records), the final scale fit runs on every fit
CPI, and step 3 checks the twin on every fit CPI: only these grow with the duration
(``alpha_recheck`` + 2 record syntheses and spectrograms).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import pandas as pd
from scipy.signal import butter, sosfilt, sosfilt_zi

from ..configfields import check_keys, check_ranges, config_names, knob
from ..causes.heldout import folds
from ..io.flightzarr import Flight, read_flight
from ..io.inventory import list_flights, read_ingested_log
from ..spectra.lines import herm_windows
from ..spectra.periodogram import stft, window
from ..spectra.spectrogram import Spectrogram, SpectrogramConfig, cpi_grid
from ..synthesis.model import (
    ENVELOPE_SPEED_STRIDE,
    BladeModel,
    ModelExtensions,
    Scaling,
    SynthesisConfig,
    Track,
    synthesize,
)
from .injection import SYNTHETIC_SCHEMA, inject
from .lines import LineSNR, body_doppler_hz, log_rate_at, rotor_rate_at
from .batches import batch_filter
from .extended import twin_extensions
from .speeds import BASE_SAMPLING, open_speeds, read_rev_s
from .stores import flight_ids, put_array, stable_seed, writing_store
from .tables import TABLE_IV_COLUMNS

#: CPIs per FFT batch of the STFT (bounds its working memory to ~32 MiB)
_FFT_BATCH = 1024


@dataclass(frozen=True)
class CalibrationConfig:
    """Settings of the per-flight fit.

    Parameters
    ----------
    tolerance_db : float
        Allowed |twin - measured| flight-mean SNR of the body and first sideband [dB].
    visible_db : float
        Median SNR over timesteps above which a sideband pair counts as visible [dB].
    search_hz : float
        Search half-width of the body line and base half-width of the sidebands [Hz].
    n_harmonics : int
        Sideband pairs measured.
    alpha_min_s, alpha_max_s : float
        Range of the alpha grid [s] (H(f) = exp(-alpha |f|)).
    n_alpha : int
        Log-spaced alphas tried (alpha = 0 is tried too).
    max_iter : int
        Scaling updates per alpha.
    remove_blade_mean : bool
        Remove the blade signal's mean over a revolution (its zero-Doppler term,
        M x mean of G), which lies on the body line: without it S_body cannot lower
        the body line below what S_blade puts there, so flights whose first sideband
        is stronger than the body (common in measured data) could not be fitted.
        The body line is then set by S_body alone, as the paper's separate body and
        blade scaling intends.
    holdout_block_cpis : int
        The calibration targets (and the twin's lines it compares with them) are
        measured on fold A only: alternating blocks of this many CPIs, CPI i in fold
        A when ``(i // holdout_block_cpis) % 2 == 0`` (as the diagnosis' folds,
        ``diagnosis.hypotheses.folds``); fold B is left for held-out fidelity scoring
        (``microdoppler.datasets.fidelity``). 0 fits on every CPI.
    max_fit_cpis : int
        Most fit CPIs (spectrogram timesteps of fold A) the alpha search (with its
        scale fits) reads: runs of ``fit_run_cpis`` consecutive fold-A CPIs spread
        evenly over the flight (:meth:`search_cpis`), so its cost does not grow with
        the flight's duration. Its best ``alpha_recheck`` alphas are ranked again,
        and the final scale fit and the twin's check run, on every fold-A CPI.
        0 searches on every fold-A CPI.

    The fields from ``highpass_margin_pulses`` on are fixed settings (``config=False``:
    no key of ``datasets.calibration`` sets them), each described by its field.
    """

    tolerance_db: float = knob(
        2.0,
        "Allowed |twin - measured| flight-mean SNR of body and first sideband [dB]; a flight beyond it is flagged "
        "'missed'.",
        exclusive_minimum=0,
    )
    visible_db: float = knob(10.0, "Median SNR over timesteps above which a sideband pair counts as visible [dB].")
    search_hz: float = knob(10.0, config=False)
    n_harmonics: int = knob(6, "Sideband pairs measured.", minimum=1)
    alpha_min_s: float = knob(1e-4, "Smallest non-zero alpha tried [s] (H(f) = exp(-alpha |f|)).", exclusive_minimum=0)
    alpha_max_s: float = knob(0.05, "Largest alpha tried [s].", exclusive_minimum=0)
    n_alpha: int = knob(12, "Log-spaced alphas tried (plus alpha = 0).", minimum=1)
    max_iter: int = knob(8, "Fixed-point updates of S_body and S_blade in the final fit.", minimum=1)
    remove_blade_mean: bool = knob(True, config=False)
    holdout_block_cpis: int = knob(
        8,
        "The calibration sees only fold A of the measured flight's CPIs (alternating blocks of this many CPIs, as "
        "diagnosis.block_cpis); fold B is held out for the fidelity report (Table VI). 0 fits on every CPI (the "
        "twins then have no held-out CPIs).",
        minimum=0,
    )
    max_fit_cpis: int = knob(
        64,
        "Most fold-A CPIs the alpha and scale search reads (runs of 4 consecutive CPIs spread evenly over the "
        "flight; the body and blade are synthesised only around them), so the search costs the same for any flight "
        "duration; its best 3 alphas are ranked again, and the final scale fit and the twin's check run, on every "
        "fold-A CPI. 0 searches on every fold-A CPI. 64: the same alphas and held-out fidelity as the search on all "
        "of fold A at a fraction of its time (docs/experiments.md, 'Calibration cost').",
        minimum=0,
    )
    highpass_margin_pulses: int = knob(
        2048,
        "Pulses synthesised and high-passed beyond each end of a run of calibration CPIs: the zero-phase 15 Hz "
        "Butterworth high-pass of a segment then matches the whole record's within ~1e-3 dB on every line and "
        "floor the fit reads (docs/experiments.md, 'Calibration cost').",
        minimum=0,
        config=False,
    )
    fit_run_cpis: int = knob(
        4,
        "Consecutive fit CPIs per run of the capped calibration subset (runs cost (run - 1) hops + one CPI + 2 "
        "margins of synthesis; the runs are spread evenly).",
        minimum=1,
        config=False,
    )
    alpha_recheck: int = knob(
        3,
        "Alphas of a capped search (best first) tried again on every fit CPI, whole records.",
        minimum=1,
        config=False,
    )
    final_tol_fraction: int = knob(
        4,
        "The final scale fit stops below tolerance_db / (4 x this) (the search: / 4).",
        exclusive_minimum=0,
        config=False,
    )

    def __post_init__(self):
        if not self.tolerance_db > 0:
            raise ValueError(f"tolerance_db={self.tolerance_db} must be > 0")
        if not self.search_hz > 0:
            raise ValueError(f"search_hz={self.search_hz} must be > 0")
        if self.n_harmonics < 1:
            raise ValueError(f"n_harmonics={self.n_harmonics} must be >= 1")
        if not 0 < self.alpha_min_s < self.alpha_max_s:
            raise ValueError(
                f"alpha_min_s={self.alpha_min_s}, alpha_max_s={self.alpha_max_s} must satisfy 0 < min < max"
            )
        if self.n_alpha < 1 or self.max_iter < 1:
            raise ValueError(f"n_alpha={self.n_alpha} and max_iter={self.max_iter} must be >= 1")
        if self.holdout_block_cpis < 0:
            raise ValueError(f"holdout_block_cpis={self.holdout_block_cpis} must be >= 0")
        if self.max_fit_cpis < 0:
            raise ValueError(f"max_fit_cpis={self.max_fit_cpis} must be >= 0 (0: every fit CPI)")
        check_ranges(self, "datasets.calibration", all_fields=True)  # the config=False knobs' ranges too

    @classmethod
    def from_config(cls, calibration: dict | None, search_hz: float, source="config") -> "CalibrationConfig":
        """From the config's ``datasets.calibration:`` section and
        ``datasets.snr_search_hz``; an unknown key is a one-line
        :class:`~microdoppler.errors.ConfigError` naming it and the section."""
        d = check_keys(calibration, config_names(cls), "datasets.calibration", source)
        return cls(search_hz=search_hz, **d)

    def fit_mask(self, n_timesteps: int) -> np.ndarray:
        """CPIs the calibration sees: bool [n_timesteps] (fold A; all when holdout is off)."""
        if self.holdout_block_cpis == 0:
            return np.ones(n_timesteps, bool)
        return folds(n_timesteps, self.holdout_block_cpis) == 0

    def search_cpis(self, fit_mask: np.ndarray) -> np.ndarray:
        """Indices of the CPIs the alpha and scale search reads: int [n_search], a
        subset of ``fit_mask`` (bool [n_timesteps]).

        Every fit CPI when ``max_fit_cpis`` is 0 or not smaller than their number;
        else the fit CPIs cut into runs of at most ``fit_run_cpis`` consecutive CPIs
        and ``ceil(max_fit_cpis / fit_run_cpis)`` of those runs evenly spaced (first
        and last included), truncated to ``max_fit_cpis`` CPIs. Deterministic.
        """
        idx = np.flatnonzero(np.asarray(fit_mask, bool))
        cap = self.max_fit_cpis
        if cap == 0 or len(idx) <= cap:
            return idx
        breaks = np.flatnonzero(np.diff(idx) != 1) + 1
        run = self.fit_run_cpis
        runs = [p[i : i + run] for p in np.split(idx, breaks) for i in range(0, len(p), run)]
        n_runs = min(len(runs), -(-cap // run))
        pick = np.unique(np.round(np.linspace(0, len(runs) - 1, n_runs)).astype(int))
        return np.sort(np.concatenate([runs[i] for i in pick]))[:cap]

    def alphas(self) -> np.ndarray:
        return np.concatenate([[0.0], np.geomspace(self.alpha_min_s, self.alpha_max_s, self.n_alpha)])


@dataclass
class LineTargets:
    """What a flight's spectrogram shows: flight-mean body and first-sideband SNR [dB],
    visible pairs and the median SNR of each pair."""

    body_db: float
    sideband1_db: float
    n_pairs: int
    harmonics_db: np.ndarray

    @classmethod
    def of(cls, lines: LineSNR, visible_db: float) -> "LineTargets":
        return cls(
            lines.body_mean_db(), lines.sideband_mean_db(1), lines.n_pairs(visible_db), lines.harmonic_medians_db()
        )


class StftColumns:
    """The spectrogram chain of :func:`microdoppler.spectra.spectrogram.spectrogram` cut in two:
    :meth:`highpass` (linear, whole record or a segment) and :meth:`columns` (the
    complex STFT, central bins, of chosen CPIs: :func:`microdoppler.spectra.periodogram.stft`
    in single precision). ``power_db(columns)`` of the whole
    high-passed record equals the spectrogram's ``power_db`` (float32 rounding), and
    since both steps are linear the columns of a sum are the sum of the columns.

    Parameters
    ----------
    n_pulses : int
        Record length [pulses] (sets the CPIs: windows wholly inside the record).
    prf_hz : float
    cfg : SpectrogramConfig
    """

    def __init__(self, n_pulses: int, prf_hz: float, cfg: SpectrogramConfig):
        if n_pulses < cfg.n_fft:
            raise ValueError(f"record of {n_pulses} pulses is shorter than one CPI (n_fft={cfg.n_fft})")
        self.prf_hz, self.cfg, self.n_pulses = float(prf_hz), cfg, int(n_pulses)
        #: first pulse of each CPI's window, int64 [n_timesteps]
        self.frame_start, self.time_s, doppler_hz = cpi_grid(n_pulses, prf_hz, cfg)
        self.window = window(cfg.n_fft).astype(np.float32)
        self.sos = (
            butter(cfg.highpass_order, cfg.highpass_hz, btype="highpass", fs=prf_hz, output="sos")
            if cfg.highpass_hz > 0
            else None
        )
        if self.sos is not None:  # sosfiltfilt's defaults (padtype "odd", padlen 3 ntaps), designed once
            ntaps = 2 * len(self.sos) + 1 - min((self.sos[:, 2] == 0).sum(), (self.sos[:, 5] == 0).sum())
            self._edge, self._zi = 3 * int(ntaps), sosfilt_zi(self.sos)
        n = cfg.n_fft
        lo = n // 2 - cfg.n_bins // 2
        keep = np.arange(n) if not cfg.n_bins else np.arange(lo, lo + cfg.n_bins)
        self.doppler_hz = doppler_hz[keep]
        self.bins = (keep + n // 2) % n  # centred bin j is unshifted FFT bin (j + n/2) mod n (n even)
        if n % 2:
            self.bins = (keep + (n + 1) // 2) % n

    @property
    def n_timesteps(self) -> int:
        return len(self.time_s)

    def highpass(self, x: np.ndarray) -> np.ndarray:
        """The spectrogram's zero-phase high-pass of ``x`` (complex64 [n]):
        :func:`microdoppler.spectra.spectrogram.highpass` (``scipy.signal.sosfiltfilt`` with its
        defaults, the same operations) with the filter and its initial state designed once."""
        x = np.asarray(x)
        if self.sos is None:
            return x
        e = self._edge
        if len(x) <= e:
            raise ValueError(f"segment of {len(x)} pulses is too short for the high-pass (needs > {e})")
        ext = np.concatenate((2 * x[:1] - x[e:0:-1], x, 2 * x[-1:] - x[-2 : -(e + 2) : -1]))
        y, _ = sosfilt(self.sos, ext, zi=self._zi * ext[0])
        y, _ = sosfilt(self.sos, y[::-1], zi=self._zi * y[-1])
        return y[::-1][e:-e].astype(np.complex64)

    def columns(self, hp: np.ndarray, cpis: np.ndarray, offset: int = 0) -> np.ndarray:
        """Complex STFT of CPIs ``cpis`` (int [k]) of the high-passed ``hp``, whose first
        sample is pulse ``offset`` of the record: complex64 [k, n_bins]."""
        cpis = np.asarray(cpis, np.int64)
        out = np.empty((len(cpis), len(self.bins)), np.complex64)
        n = self.cfg.n_fft
        for c0 in range(0, len(cpis), _FFT_BATCH):
            s = self.frame_start[cpis[c0 : c0 + _FFT_BATCH]] - offset
            if len(s) and (s.min() < 0 or s.max() + n > len(hp)):
                raise ValueError(
                    f"CPI windows [{s.min() + offset}, {s.max() + offset + n}) are not all inside "
                    f"the segment [{offset}, {offset + len(hp)})"
                )
            out[c0 : c0 + len(s)] = stft(hp, n, starts=s, window=self.window, bins=self.bins, dtype=np.complex64)
        return out

    def spectrogram(self, x: np.ndarray, cpis: np.ndarray | None = None) -> Spectrogram:
        """The spectrogram of the whole record ``x`` (complex64 [n_pulses]) at ``cpis``
        (default every CPI)."""
        cpis = np.arange(self.n_timesteps) if cpis is None else np.asarray(cpis)
        return Spectrogram(power_db(self.columns(self.highpass(x), cpis)), self.time_s[cpis], self.doppler_hz)


def power_db(columns: np.ndarray) -> np.ndarray:
    """10 log10 |S|^2 of complex STFT columns, as the spectrogram: float32 [k, n_bins]."""
    p = columns.real.astype(np.float32) ** 2 + columns.imag.astype(np.float32) ** 2
    return (10 * np.log10(p + 1e-30)).astype(np.float32)


class LineWindows:
    """:func:`~microdoppler.datasets.lines.measure_lines` with its search windows
    (:func:`microdoppler.spectra.lines.herm_windows`) laid out once: the same windows, the same peak-over-median-floor SNR, for any number
    of spectrograms on the same CPIs (vectorised over timesteps).

    Parameters
    ----------
    doppler_hz : ndarray [n_bins]
    body_hz : ndarray [n_timesteps]
        Expected body Doppler [Hz].
    rotor_rev_s : ndarray [n_timesteps] or None
        Mean rotor rate [rev/s]; None measures the body only.
    n_blades, rotor_half_spread_rev_s, n_harmonics, search_hz
        As :func:`~microdoppler.datasets.lines.measure_lines`.
    """

    def __init__(
        self,
        doppler_hz,
        body_hz,
        rotor_rev_s,
        *,
        n_blades: int,
        rotor_half_spread_rev_s: float,
        n_harmonics: int,
        search_hz: float,
    ):
        f = np.asarray(doppler_hz, np.float64)
        body = np.asarray(body_hz, np.float64)
        n_t = len(body)
        centres, widths, inside = [body], [search_hz], [np.ones(n_t, bool)]
        self.n_harmonics = 0
        if rotor_rev_s is not None:
            self.n_harmonics = n_harmonics
            windows = herm_windows(
                body,
                rotor_rev_s,
                n_blades=n_blades,
                rotor_half_spread_rev_s=rotor_half_spread_rev_s,
                n_harmonics=n_harmonics,
                search_hz=search_hz,
            )
            for _, _, c, hw in windows:  # upper then lower, k = 1..n_harmonics
                centres.append(c)
                widths.append(hw)
                inside.append((c - hw >= f[0]) & (c + hw <= f[-1]))
        c = np.stack(centres)  # [n_windows, n_t]
        w = np.asarray(widths, np.float64)[:, None, None]
        #: bool [n_windows, n_t, n_bins]: the bins each window searches at each timestep
        self.mask = np.abs(f[None, None, :] - c[:, :, None]) <= w
        self.inside = np.stack(inside)

    def measure(self, power_db: np.ndarray) -> tuple[LineSNR, np.ndarray]:
        """LineSNR of a spectrogram ``power_db`` (float32 [n_t, n_bins]) and its median
        floor per timestep [dB]."""
        floor = np.median(power_db, axis=1)
        peak = np.where(self.mask, power_db[None], np.float32(-np.inf)).max(axis=2).astype(np.float64)
        snr = np.where(self.inside, peak - floor, -np.inf)
        n_t = power_db.shape[0]
        k = self.n_harmonics
        up = snr[1::2] if k else np.full((0, n_t), -np.inf)
        lo = snr[2::2] if k else np.full((0, n_t), -np.inf)
        return LineSNR(snr[0], up, lo), floor


class TwinMeter:
    """Measures body and sideband lines of records of one flight (measured or twin).

    ``rotor_rev_s`` [n_timesteps] and ``half_spread_rev_s`` place the HERM windows.
    ``fit_mask`` (bool [n_timesteps], optional) keeps only those timesteps in every
    measurement (the calibration's fold).
    """

    def __init__(
        self, flight: Flight, spec_cfg: SpectrogramConfig, cfg: CalibrationConfig, fit_mask: np.ndarray | None = None
    ):
        self.flight, self.spec_cfg, self.cfg = flight, spec_cfg, cfg
        self.n_blades = int(flight.attrs["n_blades"])
        self.stft = StftColumns(len(flight.iq), flight.prf_hz, spec_cfg)
        self.measured_spec = self.stft.spectrogram(flight.iq)
        self.time_s = self.measured_spec.time_s
        self.body_hz = body_doppler_hz(
            flight.track_time_s, flight.track_radial_velocity_mps, flight.wavelength_m, self.time_s
        )
        n_t = len(self.time_s)
        self.fit_mask = cfg.fit_mask(n_t) if fit_mask is None else np.asarray(fit_mask, bool)
        if self.fit_mask.shape != (n_t,) or not self.fit_mask.any():
            raise ValueError(f"fit_mask must be bool [{n_t}] with at least one True, got {self.fit_mask.shape}")

    def spec(self, iq):
        """Spectrogram of a whole record (complex64 [n_pulses]) at every CPI."""
        return self.stft.spectrogram(iq)

    def windows(self, cpis: np.ndarray, rotor_rev_s, half_spread_rev_s) -> LineWindows:
        """Search windows of the body and sideband lines at CPIs ``cpis`` (int [k];
        ``rotor_rev_s`` [n_timesteps] or None)."""
        cpis = np.asarray(cpis)
        rate = None if rotor_rev_s is None else np.asarray(rotor_rev_s)[cpis]
        return LineWindows(
            self.stft.doppler_hz,
            self.body_hz[cpis],
            rate,
            n_blades=self.n_blades,
            rotor_half_spread_rev_s=half_spread_rev_s,
            n_harmonics=self.cfg.n_harmonics,
            search_hz=self.cfg.search_hz,
        )

    def lines(self, spec, rotor_rev_s, half_spread_rev_s) -> LineSNR:
        """Lines of a whole-record spectrogram ``spec`` on the fit CPIs."""
        if len(spec.time_s) != len(self.fit_mask):
            raise ValueError(f"fit_mask has {len(self.fit_mask)} timesteps, the spectrogram {len(spec.time_s)}")
        cpis = np.flatnonzero(self.fit_mask)
        return self.windows(cpis, rotor_rev_s, half_spread_rev_s).measure(spec.power_db[cpis])[0]


def _segments(stft: StftColumns, cpis: np.ndarray, margin: int) -> list[tuple[int, int]]:
    """Pulse spans [a, b) covering the windows of ``cpis`` plus ``margin`` pulses each
    side (clipped to the record; ``a`` on the synthesis' speed grid), merged."""
    n = stft.cfg.n_fft
    out: list[list[int]] = []
    for s in stft.frame_start[np.sort(np.asarray(cpis))]:
        a = max(0, int(s) - margin)
        a -= a % ENVELOPE_SPEED_STRIDE
        b = min(stft.n_pulses, int(s) + n + margin)
        if out and a <= out[-1][1]:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return [(a, b) for a, b in out]


def _db_gain(err_db: float) -> float:
    return float(10 ** (np.clip(err_db, -60, 60) / 20))


def fit_scales(
    windows: LineWindows,
    body_cols,
    blade_cols,
    background_cols,
    targets: LineTargets,
    *,
    s_body0: float,
    s_blade0: float,
    max_iter: int,
    tol_db: float,
):
    """Fixed-point fit of S_body and S_blade to the targets on the STFT columns
    (complex64 [n_cpis, n_bins]) of the unit body, unit blade and background records;
    returns (s_body, s_blade, lines) with ``lines`` the LineSNR of the last evaluated step."""
    s_b, s_m = s_body0, s_blade0
    fit_blade = np.isfinite(targets.sideband1_db)
    lines = None
    for _ in range(max_iter):
        cols = np.float32(s_b) * body_cols + np.float32(s_m) * blade_cols + background_cols
        lines = windows.measure(power_db(cols))[0]
        e_b = targets.body_db - lines.body_mean_db()
        e_m = targets.sideband1_db - lines.sideband_mean_db(1) if fit_blade else 0.0
        if not np.isfinite(e_m):
            e_m = 0.0
        if abs(e_b) < tol_db / 4 and abs(e_m) < tol_db / 4:
            break
        s_b *= _db_gain(e_b)
        s_m *= _db_gain(e_m)
    return s_b, s_m, lines


def _abs_peak_db(lines_db: np.ndarray, floor_db: np.ndarray) -> float:
    """Mean absolute peak [dB] of a line measured in a noise-free spectrogram."""
    x = lines_db + floor_db
    x = x[np.isfinite(x)]
    return float(np.mean(x)) if x.size else np.nan


def fit_twin(
    flight: Flight,
    rev_s: np.ndarray,
    motor_log,
    *,
    spec_cfg: SpectrogramConfig,
    cfg: CalibrationConfig = CalibrationConfig(),
    seed: int = 0,
    extensions: Callable[[int], ModelExtensions] | None = None,
    post: Callable[[np.ndarray], np.ndarray] | None = None,
    fit_mask: np.ndarray | None = None,
    blade_amplitudes=None,
) -> tuple[np.ndarray, dict]:
    """Synthesise and calibrate the twin of one measured drone flight.

    Parameters
    ----------
    flight : Flight
        The measured flight (needs ``background_iq`` and the rotor attrs).
    rev_s : ndarray, float32 [n_pulses, n_motors]
        The twin's rotor rates [rev/s] (a sampling variant of the log).
    motor_log : MotorLog
        The log that locates the measured flight's HERM lines.
    spec_cfg : SpectrogramConfig
        The STFT the SNRs are measured on (the classifier's).
    cfg : CalibrationConfig
        Settings of the fit (tolerance, alpha grid, held-out blocks, ...).
    seed : int
        Seed of the twin (initial rotor angles, the extensions' draws).
    extensions : callable, optional
        ``extensions(seed) -> ModelExtensions``: the model extensions acting inside
        ``synthesize`` (``SynthesisConfig.extensions``).
        With it (or ``post``) the search synthesises whole records (the extensions'
        processes run over the whole flight), without it only the pulses around the
        search CPIs.
    post : callable, optional
        ``post(iq) -> iq`` applied to the target echo (extensions); must be linear.
    fit_mask : ndarray, bool [n_timesteps], optional
        Spectrogram timesteps (CPIs) the calibration targets are measured on; default
        ``cfg.fit_mask`` (fold A of ``cfg.holdout_block_cpis``; every CPI when 0).
        The other CPIs are never seen by the fit (held-out fidelity scoring). The
        search reads ``cfg.search_cpis`` of them (at most ``cfg.max_fit_cpis``).
    blade_amplitudes : array-like, float [n_blades] or [n_motors, n_blades], optional
        Each blade's scattering amplitude (``BladeModel.blade_amplitudes``; the
        ``blade_imbalance`` extension, ``ExtensionSet.blade_amplitudes``); default
        eq. (1)'s equal blades.

    Returns
    -------
    iq : ndarray, complex64 [n_pulses]
        The calibrated twin, target only.
    result : dict
        Fitted alpha_s, s_body, s_blade, measured and achieved SNRs (on all fit CPIs),
        errors, status, ``holdout_block_cpis`` (None for a caller's ``fit_mask``, whose
        CPI indices are then in ``fit_cpis``), ``n_fit_cpis``/``n_cpis`` and
        ``n_search_cpis`` (the CPIs the search read).

    Raises
    ------
    microdoppler.errors.InputError
        When the flight has no ``background/iq``.

    See Also
    --------
    inject, microdoppler.rotors.resample, microdoppler.synthesis.synthesize

    Examples
    --------
    The twin of a 2 s emulated Inspire 2, driven by its logged speeds (``sub_cpi``):

    >>> from microdoppler.datasets import fit_twin
    >>> from microdoppler.emulator import FlightSpec, emulate_flight
    >>> from microdoppler.io import MotorLog
    >>> from microdoppler.rotors import resample
    >>> from microdoppler.spectra import SpectrogramConfig
    >>> flight, _ = emulate_flight(FlightSpec("demo", "drone", drone_model="inspire2", duration_s=2.0,
    ...                                       mean_range_m=600.0, path="straight", snr_db=40.0, seed=1))
    >>> log = MotorLog(flight.motors_time_s, flight.motors_rpm)
    >>> rev_s = resample("sub_cpi", log, len(flight.iq), flight.prf_hz)
    >>> twin_iq, fit = fit_twin(flight, rev_s, log, spec_cfg=SpectrogramConfig(), seed=0)
    >>> twin_iq.shape == flight.iq.shape, twin_iq.dtype, fit["status"]
    (True, dtype('complex64'), 'ok')
    >>> sorted(k for k in fit if k in ("alpha_s", "s_blade", "s_body"))
    ['alpha_s', 's_blade', 's_body']
    """
    t0 = time.perf_counter()
    n = len(flight.iq)
    bg = flight.background_iq
    if bg is None:
        inject(flight.iq, None, "flight")  # the one error for a missing background
    meter = TwinMeter(flight, spec_cfg, cfg, fit_mask)
    stft = meter.stft
    fit_cpis = np.flatnonzero(meter.fit_mask)
    cpis = cfg.search_cpis(meter.fit_mask)
    # measured flight: HERM windows from the log; search targets on the search CPIs
    m_rate, m_spread = log_rate_at(motor_log.time_s, motor_log.rev_s, meter.time_s)
    m_spread_flight = float(np.percentile(m_spread, 90))
    meas_db = meter.measured_spec.power_db
    targets = LineTargets.of(meter.windows(cpis, m_rate, m_spread_flight).measure(meas_db[cpis])[0], cfg.visible_db)
    # twin: HERM windows from its own rates
    t_rate, t_spread = rotor_rate_at(rev_s, meter.time_s, flight.prf_hz)
    t_spread_flight = float(np.percentile(t_spread, 90))
    win = meter.windows(cpis, t_rate, t_spread_flight)
    body_win = meter.windows(cpis, None, 0)
    track = Track.from_tracker(flight.track_time_s, flight.track_range_m, flight.track_radial_velocity_mps)
    blades = BladeModel(
        int(flight.attrs["n_blades"]),
        float(flight.attrs["blade_length_m"]),
        flight.wavelength_m,
        blade_amplitudes=blade_amplitudes,
    )

    n_motors = rev_s.shape[1]
    blade_mean = complex(blades.table().mean())
    whole = extensions is not None or post is not None
    segs = _segments(stft, cpis, cfg.highpass_margin_pulses)  # whole: synthesised whole, high-passed in segments
    # segment synthesis starts each segment at the whole record's rotor angles: the
    # seed's initial angles (as synthesize draws them) plus the turns up to the segment
    start_cycles = np.random.default_rng(seed).uniform(0, 1, n_motors)
    starts = np.array([a for a, _ in segs], np.int64)
    turns = np.zeros((len(segs), n_motors))
    seg_tracks = {}
    if not whole:
        cum = np.cumsum(np.asarray(rev_s[: int(starts.max())], np.float64), axis=0) if starts.max() > 0 else None
        for i, a in enumerate(starts):
            if a > 0:
                turns[i] = cum[a - 1] / flight.prf_hz

    def synth(scaling, a=0, b=n, turns_a=None):
        ext = extensions(seed) if extensions is not None else ModelExtensions()
        if cfg.remove_blade_mean and scaling.s_blade > 0:
            env = ext.envelope_gain
            dc = np.complex64(
                scaling.s_blade
                * n_motors
                * blade_mean
                * (complex(np.asarray(env(np.zeros(1)))[0]) if env is not None else 1.0)
            )
            then = ext.blade_hook

            def hook(i0, i1, t_s, x, dc=dc, then=then):
                x -= dc
                if then is not None:
                    then(i0, i1, t_s, x)

            ext = replace(ext, blade_hook=hook)
        config = SynthesisConfig(flight.prf_hz, blades, scaling, extensions=ext)
        if a == 0 and b == n:
            iq = synthesize(config, track, rev_s, n_pulses=n, seed=seed)
            return post(iq) if post is not None else iq
        init = np.mod(start_cycles + turns_a, 1.0)
        seg_track = seg_tracks.get(a)
        if seg_track is None:
            seg_track = seg_tracks[a] = Track(track.time_s - a / flight.prf_hz, track.range_m)
        return synthesize(config, seg_track, rev_s[a:b], n_pulses=b - a, initial_cycles=init)

    # CPI -> segment: the search CPIs' columns are gathered segment by segment
    seg_of = np.searchsorted(starts, stft.frame_start[cpis], side="right") - 1

    def columns(scaling) -> np.ndarray:
        """STFT columns of a unit component at the search CPIs: complex64 [n_search, n_bins]."""
        out = np.empty((len(cpis), len(stft.bins)), np.complex64)
        record = synth(scaling) if whole else None
        for i, (a, b) in enumerate(segs):
            sel = seg_of == i
            if sel.any():
                x = record[a:b] if whole else synth(scaling, a, b, turns[i])
                out[sel] = stft.columns(stft.highpass(x), cpis[sel], offset=a)
        return out

    bg_hp = stft.highpass(bg)
    bg_cols = stft.columns(bg_hp, cpis)
    bg_floor = float(np.mean(np.median(power_db(bg_cols), axis=1)))
    body_cols = columns(Scaling(1.0, 0.0, 0.0))
    lines_b, floor_b = body_win.measure(power_db(body_cols))
    s_body0 = _db_gain(targets.body_db + bg_floor - _abs_peak_db(lines_b.body_db, floor_b))
    tol = cfg.tolerance_db

    def trial(alpha, blade_cols, targets, win, body_cols, bg_cols, s_body0, s_blade0):
        """Scale fit at one alpha and its sort key (missed, |pairs error|, profile)."""
        s_b, s_m, lines = fit_scales(
            win,
            body_cols,
            blade_cols,
            bg_cols,
            targets,
            s_body0=s_body0,
            s_blade0=s_blade0,
            max_iter=max(3, cfg.max_iter // 2),
            tol_db=tol,
        )
        got = LineTargets.of(lines, cfg.visible_db)
        both = np.isfinite(targets.harmonics_db[1:]) & np.isfinite(got.harmonics_db[1:])
        profile = (
            float(np.mean(np.abs(targets.harmonics_db[1:][both] - got.harmonics_db[1:][both]))) if both.any() else 0.0
        )
        err = max(
            abs(got.body_db - targets.body_db),
            abs(got.sideband1_db - targets.sideband1_db) if np.isfinite(targets.sideband1_db) else 0.0,
        )
        return (not (err <= tol), abs(got.n_pairs - targets.n_pairs), profile, float(alpha), s_b, s_m, blade_cols)

    trials = []
    for alpha in cfg.alphas():
        blade_cols = columns(Scaling(0.0, 1.0, float(alpha)))
        lines_m, floor_m = win.measure(power_db(blade_cols))
        pk = _abs_peak_db(lines_m.pair_db[0], floor_m)
        s_blade0 = _db_gain(targets.sideband1_db + bg_floor - pk) if np.isfinite(pk + targets.sideband1_db) else 1e-6
        trials.append(trial(alpha, blade_cols, targets, win, body_cols, bg_cols, s_body0, s_blade0))
    # a fit within tolerance first (a blade so strong that its mean over a revolution
    # swamps the body line cannot be fitted), then the count, then the harmonic profile
    trials.sort(key=lambda r: r[:3])
    if len(cpis) < len(fit_cpis):
        # a capped search: its best cfg.alpha_recheck alphas are tried again on every fit
        # CPI (whole body and blade records), starting from the scales it found
        targets = LineTargets.of(
            meter.windows(fit_cpis, m_rate, m_spread_flight).measure(meas_db[fit_cpis])[0], cfg.visible_db
        )
        win = meter.windows(fit_cpis, t_rate, t_spread_flight)
        body_cols = stft.columns(stft.highpass(synth(Scaling(1.0, 0.0, 0.0))), fit_cpis)
        bg_cols = stft.columns(bg_hp, fit_cpis)
        best = [r[3:6] for r in trials[: cfg.alpha_recheck]]  # (alpha, s_body, s_blade)
        trials = sorted(
            (
                trial(
                    a,
                    stft.columns(stft.highpass(synth(Scaling(0.0, 1.0, a))), fit_cpis),
                    targets,
                    win,
                    body_cols,
                    bg_cols,
                    sb,
                    sm,
                )
                for a, sb, sm in best
            ),
            key=lambda r: r[:3],
        )
    alpha, s_b, s_m, blade_cols = trials[0][3:]
    del trials
    # final fit on every fit CPI, to a sixteenth of the tolerance (steps cost no
    # synthesis): where in the +-tolerance/4 window a search stopped is otherwise left
    # to chance, and shows on the held-out CPIs
    s_b, s_m, _ = fit_scales(
        win,
        body_cols,
        blade_cols,
        bg_cols,
        targets,
        s_body0=s_b,
        s_blade0=s_m,
        max_iter=cfg.max_iter,
        tol_db=tol / cfg.final_tol_fraction,
    )
    del body_cols, blade_cols, bg_cols, bg_hp
    # check: synthesise the whole twin from scratch with the fitted values, inject and
    # measure on every fit CPI (targets too)
    iq = synth(Scaling(float(s_b), float(s_m), alpha)).astype(np.complex64)
    measured = LineTargets.of(
        meter.windows(fit_cpis, m_rate, m_spread_flight).measure(meas_db[fit_cpis])[0], cfg.visible_db
    )
    twin_db = power_db(stft.columns(stft.highpass(inject(iq, bg)), fit_cpis))
    got = LineTargets.of(meter.windows(fit_cpis, t_rate, t_spread_flight).measure(twin_db)[0], cfg.visible_db)
    e_body = got.body_db - measured.body_db
    e_sb = got.sideband1_db - measured.sideband1_db
    ok = abs(e_body) <= tol and (not np.isfinite(measured.sideband1_db) or abs(e_sb) <= tol)
    result = dict(
        alpha_s=alpha,
        s_body=float(s_b),
        s_blade=float(s_m),
        n_pairs_measured=measured.n_pairs,
        n_pairs_twin=got.n_pairs,
        body_snr_measured_db=measured.body_db,
        body_snr_twin_db=got.body_db,
        body_error_db=float(e_body),
        sideband1_snr_measured_db=measured.sideband1_db,
        sideband1_snr_twin_db=got.sideband1_db,
        sideband1_error_db=float(e_sb),
        status="ok" if ok else "missed",
        holdout_block_cpis=int(cfg.holdout_block_cpis) if fit_mask is None else None,
        n_fit_cpis=int(meter.fit_mask.sum()),
        n_cpis=len(meter.fit_mask),
        n_search_cpis=len(cpis),
        **({} if fit_mask is None else {"fit_cpis": fit_cpis.tolist()}),
        fit_seconds=round(time.perf_counter() - t0, 2),
    )
    return iq, result


def build_twins(
    measured_dir,
    speeds_zarr,
    logs_zarr,
    out,
    table_iv,
    *,
    variant: str,
    spec_cfg: SpectrogramConfig,
    cfg: CalibrationConfig,
    seed: int,
    extensions=None,
    batch: tuple[int, int] | None = None,
    log=print,
) -> pd.DataFrame:
    """Write ``results/synthetic/{variant}.zarr`` (group per twin: ``iq`` target only,
    calibration in attrs) and the per-flight Table IV of the variant.

    ``batch`` = (index, n_batches): only the flights of that flight batch
    (:func:`~microdoppler.datasets.batches.flight_batch`); their twins equal those
    written with ``batch`` None (the seeds depend on the flight id only).

    ``extensions`` (``extended`` variant): a
    :class:`~microdoppler.datasets.extended.TwinExtensions` (each twin its own
    flight's causes, or a population draw; recorded in the twin's ``extensions``
    attribute) or one set for every twin. The ``extended`` twins use ``sub_cpi``'s
    seeds, so a twin without extensions equals its ``sub_cpi`` twin."""
    speeds = open_speeds(speeds_zarr)
    flights = list_flights(measured_dir).set_index("flight_id")
    mine = batch_filter(*(batch or (None, 1)))
    rows = [
        dict(
            flight_id=fid,
            variant=variant,
            drone_model=flights.drone_model.get(fid, ""),
            radar_id=flights.radar_id.get(fid, ""),
            status=f"skipped: {why}",
        )
        for fid, why in dict(speeds.attrs.get("skipped", {})).items()
        if mine(fid)
    ]
    with writing_store(out, {"schema": SYNTHETIC_SCHEMA, "variant": variant, "target_only": True}) as root:
        for fid in filter(mine, flight_ids(speeds)):
            g = speeds[fid]
            flight = read_flight(flights.loc[fid, "path"])
            base = dict(
                flight_id=fid,
                variant=variant,
                drone_model=flight.attrs["drone_model"],
                radar_id=flight.attrs["radar_id"],
                window_pulses=g.attrs.get("window_pulses", np.nan),
                fixed_rev_s=g.attrs.get("fixed_rev_s", np.nan),
            )
            if flight.background_iq is None:
                log(f"{fid}: no background/iq: skipped (cannot inject a twin)")
                rows.append({**base, "status": "skipped: no background"})
                continue
            ml = read_ingested_log(logs_zarr, fid)
            ext = twin_extensions(extensions, fid, flight.attrs["drone_model"], seed=seed)
            active = ext is not None and bool(getattr(ext, "effects", True))
            if active:
                ml = ext.transform_log(ml)
            # extended twins share sub_cpi's seed: a twin without extensions is its sub_cpi twin
            fseed = stable_seed(seed, "twin", BASE_SAMPLING.get(variant, variant), fid)
            kw, post = {}, None
            if active:
                kw["extensions"] = lambda s, n=len(flight.iq), prf=flight.prf_hz, e=ext: e.model_extensions(
                    prf_hz=prf, n_pulses=n, seed=s
                )
                post = lambda x, prf=flight.prf_hz, s=fseed, e=ext: e.post(x, prf_hz=prf, seed=s)
                if hasattr(ext, "blade_amplitudes"):
                    kw["blade_amplitudes"] = ext.blade_amplitudes(int(flight.attrs["n_blades"]))
            iq, res = fit_twin(
                flight,
                read_rev_s(g, f"{speeds_zarr}/{fid}"),
                ml,
                spec_cfg=spec_cfg,
                cfg=cfg,
                seed=fseed,
                post=post,
                **kw,
            )
            h = root.require_group(fid)
            if ext is not None and hasattr(ext, "effects"):
                h.attrs["extensions"] = {
                    "effects": {c: dict(p) for c, p in ext.effects.items()},
                    "source": dict(getattr(ext, "meta", {})).get("source", "uniform"),
                }
            h.attrs.update(
                {
                    **flight.attrs,
                    "variant": variant,
                    "twin_of": fid,
                    "twin_seed": fseed,
                    "calibration": {
                        k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in res.items()
                    },
                    "speeds": dict(g.attrs),
                }
            )
            put_array(h, "iq", iq)
            rows.append({**base, **res})
            log(
                f"{fid}: {res['status']} alpha={res['alpha_s']:.3g} s S_body={res['s_body']:.3g} "
                f"S_blade={res['s_blade']:.3g} pairs {res['n_pairs_measured']}->{res['n_pairs_twin']} "
                f"body {res['body_error_db']:+.2f} dB sideband1 {res['sideband1_error_db']:+.2f} dB "
                f"({res['fit_seconds']} s)"
            )
    df = pd.DataFrame(rows).reindex(columns=TABLE_IV_COLUMNS)
    from .tables import write_csv

    write_csv(df, table_iv)
    return df
