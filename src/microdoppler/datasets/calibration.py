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
   S_blade (x = S_body b + S_blade m + background), so the search combines a body
   and a blade component instead of re-synthesising; each step is a multiplicative
   update by the dB error (fixed point), repeated until both errors are below a
   quarter of the tolerance or ``max_iter`` steps.
   The blade's mean over a revolution (its zero-Doppler term, which sits on the
   body line) is removed by default (``remove_blade_mean``), so S_body alone sets
   the body line.
3. The twin is then synthesised once more from scratch with the fitted Scaling,
   injected and measured: the achieved errors are recorded and a flight that misses
   ``tolerance_db`` (2 dB) on the body or first sideband is flagged ``missed``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
import pandas as pd

from ..diagnosis.causes import folds
from ..flightzarr import Flight, read_flight
from ..inventory import list_flights, read_ingested_log
from ..snr import noise_floor_db
from ..spectrogram import Spectrogram, SpectrogramConfig, spectrogram
from ..synthesis import BladeModel, Scaling, Track, synthesize
from .injection import SYNTHETIC_SCHEMA, inject
from .lines import LineSNR, body_doppler_hz, log_rate_at, measure_lines, rotor_rate_at
from .batches import batch_filter
from .extended import twin_extensions
from .speeds import BASE_SAMPLING, SPEEDS_SCHEMA
from .stores import flight_ids, open_store, put_array, stable_seed, writing_store
from .tables import TABLE_IV_COLUMNS


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
        ``diagnosis.causes.folds``); fold B is left for held-out fidelity scoring
        (``microdoppler.fidelity``). 0 fits on every CPI.
    """

    tolerance_db: float = 2.0
    visible_db: float = 10.0
    search_hz: float = 10.0
    n_harmonics: int = 6
    alpha_min_s: float = 1e-4
    alpha_max_s: float = 0.05
    n_alpha: int = 12
    max_iter: int = 8
    remove_blade_mean: bool = True
    holdout_block_cpis: int = 8

    def __post_init__(self):
        if not self.tolerance_db > 0:
            raise ValueError(f"tolerance_db={self.tolerance_db} must be > 0")
        if not self.search_hz > 0:
            raise ValueError(f"search_hz={self.search_hz} must be > 0")
        if self.n_harmonics < 1:
            raise ValueError(f"n_harmonics={self.n_harmonics} must be >= 1")
        if not 0 < self.alpha_min_s < self.alpha_max_s:
            raise ValueError(f"alpha_min_s={self.alpha_min_s}, alpha_max_s={self.alpha_max_s} must satisfy 0 < min < max")
        if self.n_alpha < 1 or self.max_iter < 1:
            raise ValueError(f"n_alpha={self.n_alpha} and max_iter={self.max_iter} must be >= 1")
        if self.holdout_block_cpis < 0:
            raise ValueError(f"holdout_block_cpis={self.holdout_block_cpis} must be >= 0")

    def fit_mask(self, n_timesteps: int) -> np.ndarray:
        """CPIs the calibration sees: bool [n_timesteps] (fold A; all when holdout is off)."""
        if self.holdout_block_cpis == 0:
            return np.ones(n_timesteps, bool)
        return folds(n_timesteps, self.holdout_block_cpis) == 0

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
        return cls(lines.body_mean_db(), lines.sideband_mean_db(1), lines.n_pairs(visible_db),
                   lines.harmonic_medians_db())


class TwinMeter:
    """Measures body and sideband lines of records of one flight (measured or twin).

    ``rotor_rev_s`` [n_timesteps] and ``half_spread_rev_s`` place the HERM windows.
    ``fit_mask`` (bool [n_timesteps], optional) keeps only those timesteps in every
    measurement (the calibration's fold).
    """

    def __init__(self, flight: Flight, spec_cfg: SpectrogramConfig, cfg: CalibrationConfig,
                 fit_mask: np.ndarray | None = None):
        self.flight, self.spec_cfg, self.cfg = flight, spec_cfg, cfg
        self.n_blades = int(flight.attrs["n_blades"])
        self.measured_spec = spectrogram(flight.iq, flight.prf_hz, spec_cfg)
        self.time_s = self.measured_spec.time_s
        self.body_hz = body_doppler_hz(flight.track_time_s, flight.track_radial_velocity_mps, flight.wavelength_m,
                                       self.time_s)
        n_t = len(self.time_s)
        self.fit_mask = cfg.fit_mask(n_t) if fit_mask is None else np.asarray(fit_mask, bool)
        if self.fit_mask.shape != (n_t,) or not self.fit_mask.any():
            raise ValueError(f"fit_mask must be bool [{n_t}] with at least one True, got {self.fit_mask.shape}")

    def spec(self, iq):
        return spectrogram(iq, self.flight.prf_hz, self.spec_cfg)

    def lines(self, spec, rotor_rev_s, half_spread_rev_s) -> LineSNR:
        body = body_doppler_hz(self.flight.track_time_s, self.flight.track_radial_velocity_mps,
                               self.flight.wavelength_m, spec.time_s)
        rate = None if rotor_rev_s is None else np.asarray(rotor_rev_s)[self.fit_mask]
        return measure_lines(_masked(spec, self.fit_mask), body[self.fit_mask], rate, n_blades=self.n_blades,
                             rotor_half_spread_rev_s=half_spread_rev_s, n_harmonics=self.cfg.n_harmonics,
                             search_hz=self.cfg.search_hz)


def _masked(spec: Spectrogram, mask: np.ndarray) -> Spectrogram:
    """The timesteps of ``spec`` where ``mask`` [n_timesteps] is True."""
    if mask.all():
        return spec
    if len(mask) != len(spec.time_s):
        raise ValueError(f"fit_mask has {len(mask)} timesteps, the spectrogram {len(spec.time_s)}")
    return Spectrogram(spec.power_db[mask], spec.time_s[mask], spec.doppler_hz)


def _abs_peak_db(lines_db: np.ndarray, spec) -> float:
    """Mean absolute peak [dB] of a line measured in a noise-free spectrogram."""
    x = lines_db + noise_floor_db(spec)
    x = x[np.isfinite(x)]
    return float(np.mean(x)) if x.size else np.nan


def _db_gain(err_db: float) -> float:
    return float(10 ** (np.clip(err_db, -60, 60) / 20))


def fit_scales(meter: TwinMeter, body_unit, blade_unit, background, targets: LineTargets, rate, spread, *,
               s_body0: float, s_blade0: float, max_iter: int, tol_db: float):
    """Fixed-point fit of S_body and S_blade to the targets; returns (s_body, s_blade, lines)."""
    s_b, s_m = s_body0, s_blade0
    fit_blade = np.isfinite(targets.sideband1_db)
    lines = None
    for _ in range(max_iter):
        x = inject(np.float32(s_b) * body_unit + np.float32(s_m) * blade_unit, background)
        lines = meter.lines(meter.spec(x), rate, spread)
        e_b = targets.body_db - lines.body_mean_db()
        e_m = targets.sideband1_db - lines.sideband_mean_db(1) if fit_blade else 0.0
        if not np.isfinite(e_m):
            e_m = 0.0
        if abs(e_b) < tol_db / 4 and abs(e_m) < tol_db / 4:
            break
        s_b *= _db_gain(e_b)
        s_m *= _db_gain(e_m)
    return s_b, s_m, lines


def fit_twin(flight: Flight, rev_s: np.ndarray, motor_log, *, spec_cfg: SpectrogramConfig,
             cfg: CalibrationConfig = CalibrationConfig(), seed: int = 0,
             synth_kwargs: Callable[[int], dict] | None = None,
             post: Callable[[np.ndarray], np.ndarray] | None = None,
             fit_mask: np.ndarray | None = None) -> tuple[np.ndarray, dict]:
    """Synthesise and calibrate the twin of one measured drone flight.

    Parameters
    ----------
    flight : Flight
        The measured flight (needs ``background_iq`` and the rotor attrs).
    rev_s : ndarray, float32 [n_pulses, n_motors]
        The twin's rotor rates [rev/s] (a sampling variant of the log).
    motor_log : MotorLog
        The log that locates the measured flight's HERM lines.
    synth_kwargs : callable, optional
        ``synth_kwargs(seed) -> dict`` extra arguments of ``synthesize`` (extensions).
    post : callable, optional
        ``post(iq) -> iq`` applied to the target echo (extensions); must be linear.
    fit_mask : ndarray, bool [n_timesteps], optional
        Spectrogram timesteps (CPIs) the calibration targets are measured on; default
        ``cfg.fit_mask`` (fold A of ``cfg.holdout_block_cpis``; every CPI when 0).
        The other CPIs are never seen by the fit (held-out fidelity scoring).

    Returns
    -------
    iq : ndarray, complex64 [n_pulses]
        The calibrated twin, target only.
    result : dict
        Fitted alpha_s, s_body, s_blade, measured and achieved SNRs (on the fit CPIs),
        errors, status, ``holdout_block_cpis`` (None for a caller's ``fit_mask``, whose
        CPI indices are then in ``fit_cpis``) and ``n_fit_cpis``/``n_cpis``.
    """
    t0 = time.perf_counter()
    n = len(flight.iq)
    bg = flight.background_iq
    meter = TwinMeter(flight, spec_cfg, cfg, fit_mask)
    # measured flight: HERM windows from the log
    m_rate, m_spread = log_rate_at(motor_log.time_s, motor_log.rev_s, meter.time_s)
    m_spread_flight = float(np.percentile(m_spread, 90))
    targets = LineTargets.of(meter.lines(meter.measured_spec, m_rate, m_spread_flight), cfg.visible_db)
    # twin: HERM windows from its own rates
    t_rate, t_spread = rotor_rate_at(rev_s, meter.time_s, flight.prf_hz)
    t_spread_flight = float(np.percentile(t_spread, 90))
    track = Track(flight.track_time_s, flight.track_range_m)
    geom = dict(prf_hz=flight.prf_hz, wavelength_m=flight.wavelength_m, n_blades=int(flight.attrs["n_blades"]),
                blade_length_m=float(flight.attrs["blade_length_m"]), n_pulses=n, seed=seed)

    n_motors = rev_s.shape[1]
    blade_mean = complex(BladeModel(geom["n_blades"], geom["blade_length_m"], geom["wavelength_m"]).table().mean())

    def synth(scaling):
        extra = dict(synth_kwargs(seed)) if synth_kwargs is not None else {}
        if cfg.remove_blade_mean and scaling.s_blade > 0:
            env = extra.get("envelope")
            dc = np.complex64(scaling.s_blade * n_motors * blade_mean
                              * (complex(np.asarray(env(np.zeros(1)))[0]) if env is not None else 1.0))
            then = extra.get("blade_hook")

            def hook(i0, i1, t_s, x, dc=dc, then=then):
                x -= dc
                if then is not None:
                    then(i0, i1, t_s, x)

            extra["blade_hook"] = hook
        iq = synthesize(rev_s, track, scaling=scaling, **geom, **extra)
        return post(iq) if post is not None else iq

    body_unit = synth(Scaling(1.0, 0.0, 0.0))
    bg_floor = float(np.mean(noise_floor_db(meter.spec(bg))))
    spec_b = meter.spec(body_unit)
    s_body0 = _db_gain(targets.body_db + bg_floor - _abs_peak_db(meter.lines(spec_b, None, 0).body_db, _masked(spec_b, meter.fit_mask)))
    tol = cfg.tolerance_db
    trials = []
    for alpha in cfg.alphas():
        blade_unit = synth(Scaling(0.0, 1.0, float(alpha)))
        spec_m = meter.spec(blade_unit)
        pk = _abs_peak_db(meter.lines(spec_m, t_rate, t_spread_flight).pair_db[0], _masked(spec_m, meter.fit_mask))
        s_blade0 = _db_gain(targets.sideband1_db + bg_floor - pk) if np.isfinite(pk + targets.sideband1_db) else 1e-6
        s_b, s_m, lines = fit_scales(meter, body_unit, blade_unit, bg, targets, t_rate, t_spread_flight,
                                     s_body0=s_body0, s_blade0=s_blade0, max_iter=max(3, cfg.max_iter // 2), tol_db=tol)
        got = LineTargets.of(lines, cfg.visible_db)
        both = np.isfinite(targets.harmonics_db[1:]) & np.isfinite(got.harmonics_db[1:])
        profile = float(np.mean(np.abs(targets.harmonics_db[1:][both] - got.harmonics_db[1:][both]))) if both.any() else 0.0
        err = max(abs(got.body_db - targets.body_db),
                  abs(got.sideband1_db - targets.sideband1_db) if np.isfinite(targets.sideband1_db) else 0.0)
        missed = not (err <= tol)
        trials.append((missed, abs(got.n_pairs - targets.n_pairs), profile, float(alpha), s_b, s_m))
    # a fit within tolerance first (a blade so strong that its mean over a revolution
    # swamps the body line cannot be fitted), then the count, then the harmonic profile
    trials.sort(key=lambda r: r[:3])
    alpha, s_b, s_m = trials[0][3:]
    blade_unit = synth(Scaling(0.0, 1.0, alpha))
    s_b, s_m, _ = fit_scales(meter, body_unit, blade_unit, bg, targets, t_rate, t_spread_flight,
                             s_body0=s_b, s_blade0=s_m, max_iter=cfg.max_iter, tol_db=tol)
    # check: synthesise from scratch with the fitted values, inject, measure
    iq = synth(Scaling(float(s_b), float(s_m), alpha)).astype(np.complex64)
    got = LineTargets.of(meter.lines(meter.spec(inject(iq, bg)), t_rate, t_spread_flight), cfg.visible_db)
    e_body = got.body_db - targets.body_db
    e_sb = got.sideband1_db - targets.sideband1_db
    ok = abs(e_body) <= tol and (not np.isfinite(targets.sideband1_db) or abs(e_sb) <= tol)
    result = dict(
        alpha_s=alpha, s_body=float(s_b), s_blade=float(s_m),
        n_pairs_measured=targets.n_pairs, n_pairs_twin=got.n_pairs,
        body_snr_measured_db=targets.body_db, body_snr_twin_db=got.body_db, body_error_db=float(e_body),
        sideband1_snr_measured_db=targets.sideband1_db, sideband1_snr_twin_db=got.sideband1_db,
        sideband1_error_db=float(e_sb), status="ok" if ok else "missed",
        holdout_block_cpis=int(cfg.holdout_block_cpis) if fit_mask is None else None,
        n_fit_cpis=int(meter.fit_mask.sum()), n_cpis=len(meter.fit_mask),
        **({} if fit_mask is None else {"fit_cpis": np.flatnonzero(meter.fit_mask).tolist()}),
        fit_seconds=round(time.perf_counter() - t0, 2),
    )
    return iq, result


def build_twins(measured_dir, speeds_zarr, logs_zarr, out, table_iv, *, variant: str, spec_cfg: SpectrogramConfig,
                cfg: CalibrationConfig, seed: int, extensions=None, batch: tuple[int, int] | None = None,
                log=print) -> pd.DataFrame:
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
    speeds = open_store(speeds_zarr, SPEEDS_SCHEMA)
    flights = list_flights(measured_dir).set_index("flight_id")
    mine = batch_filter(*(batch or (None, 1)))
    rows = [dict(flight_id=fid, variant=variant, drone_model=flights.drone_model.get(fid, ""),
                 radar_id=flights.radar_id.get(fid, ""), status=f"skipped: {why}")
            for fid, why in dict(speeds.attrs.get("skipped", {})).items() if mine(fid)]
    with writing_store(out, {"schema": SYNTHETIC_SCHEMA, "variant": variant, "target_only": True}) as root:
        for fid in filter(mine, flight_ids(speeds)):
            g = speeds[fid]
            flight = read_flight(flights.loc[fid, "path"])
            base = dict(flight_id=fid, variant=variant, drone_model=flight.attrs["drone_model"],
                        radar_id=flight.attrs["radar_id"], window_pulses=g.attrs.get("window_pulses", np.nan),
                        fixed_rev_s=g.attrs.get("fixed_rev_s", np.nan))
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
                kw["synth_kwargs"] = lambda s, n=len(flight.iq), prf=flight.prf_hz, e=ext: e.synth_kwargs(
                    prf_hz=prf, n_pulses=n, seed=s)
                post = lambda x, prf=flight.prf_hz, s=fseed, e=ext: e.post(x, prf_hz=prf, seed=s)
            iq, res = fit_twin(flight, np.asarray(g["rev_s"][...]), ml, spec_cfg=spec_cfg, cfg=cfg, seed=fseed,
                               post=post, **kw)
            h = root.require_group(fid)
            if ext is not None and hasattr(ext, "effects"):
                h.attrs["extensions"] = {"effects": {c: dict(p) for c, p in ext.effects.items()},
                                         "source": dict(getattr(ext, "meta", {})).get("source", "uniform")}
            h.attrs.update({**flight.attrs, "variant": variant, "twin_of": fid, "twin_seed": fseed,
                            "calibration": {k: (None if isinstance(v, float) and not np.isfinite(v) else v)
                                            for k, v in res.items()}, "speeds": dict(g.attrs)})
            put_array(h, "iq", iq)
            rows.append({**base, **res})
            log(f"{fid}: {res['status']} alpha={res['alpha_s']:.3g} s S_body={res['s_body']:.3g} "
                f"S_blade={res['s_blade']:.3g} pairs {res['n_pairs_measured']}->{res['n_pairs_twin']} "
                f"body {res['body_error_db']:+.2f} dB sideband1 {res['sideband1_error_db']:+.2f} dB "
                f"({res['fit_seconds']} s)")
    df = pd.DataFrame(rows).reindex(columns=TABLE_IV_COLUMNS)
    from .tables import write_csv
    write_csv(df, table_iv)
    return df
