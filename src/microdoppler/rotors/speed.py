"""Rotor speeds from the radar itself: each rotor's speed per CPI from its HERM lines.

A drone flight without a motor log still carries its rotor speeds in its spectrum:
a rotor of B equal blades turning at f_m [rev/s] puts lines at the body Doppler plus
and minus n B f_m, n = 1, 2, ... (the paper's HERM lines, §II; Fig. 2b: four rotors
give four lines in each harmonic group). :func:`estimate_rotor_speeds` measures them
on the paper's STFT (:func:`microdoppler.spectra.spectrogram.spectrogram`: ``n_fft``-point
Blackman-Harris, 50 % overlap, by default the paper's CPI of ~0.56 s and at least 4096
pulses; without the high-pass, the clutter band is masked instead) and returns a
:class:`RotorEstimate`: per CPI the rotor speeds, their mean, one-sigma uncertainties,
the number of visible sideband pairs, or a ``reason`` when the flight shows no HERM
lines.

Method (arrays per CPI):

1. Spectrum in dB over the *local* noise floor (a low percentile over
   ``FLOOR_WINDOW_BINS``, robust to the lines around a drone's body); the clutter
   band ``|f| < clutter_guard_hz`` is masked ("unknown", neither evidence for nor
   against a line). Lines are peaks with ``line_prominence_db``.
2. Centre of symmetry: HERM lines come in pairs f_c +- n B f_m, so the centre f_c is
   the half-bin near the track's Doppler (``body_search_hz``) where the mirrored line
   pattern best matches itself. Speeds below come from pair *differences*
   (f_up - f_lo), so a centre error cancels (a body in the clutter notch is fine).
3. Pair evidence: a pair is visible where both lines stand ``pair_snr_db`` over the
   floor (noise alone does so on both sides with probability ~exp(-20)). The speed
   spectrum R(f) sums the evidence of harmonics n = 1..``n_harmonics`` at n B f, on a
   grid fine enough for the highest one, and counts only where the lowest pair is
   visible: HERM lines fall off with n, so a candidate without its first pair is a
   sub-harmonic or a ghost (where n = 1 falls in the clutter band, n = 2 and 3 stand
   in).
4. Continuity prior: a Viterbi path over a 0.5 % log-speed grid (emission: the best
   R in the cell; ``step_penalty_db`` per step, at most ``max_step_rel`` per hop)
   follows the rotor group from CPI to CPI; the rotors are searched within a factor
   ``group_ratio`` of it.
5. Lines: peaks of the lowest examinable harmonic's pair spectrum form clusters
   (bounded by the minima between them). Each cluster's speed is the power-weighted
   centroid of its lines on both sides (noise subtracted; the outermost walk out
   while above the noise), at n1 and up to ``n_measure`` harmonics (while the
   harmonic groups do not overlap), combined with inverse-variance weights. A
   centroid, unlike a peak, is unbiased by the speed changing within the CPI: a
   spectrogram line's first moment is the window^2-weighted mean of its
   instantaneous frequency, which is how the per-CPI truth is defined.
6. Separation: a cluster splits into the lines that at least two higher harmonics
   resolve inside it (separations grow as n), each measured by its own centroid at
   the resolving harmonic (free of the interference between close rotors).
7. Rotor counts: with fewer lines than rotors, close rotors share a line. The counts
   per cluster are chosen from the clusters' power shares (averaged over every
   harmonic whose pair is visible anywhere in the group: close rotors interfere,
   differently at each harmonic) and the relative-speed pattern of neighbouring CPIs
   (+-``pattern_cpis``) whose every rotor had its own line; the mean speed is
   averaged over the counts' posterior. The spread of the posterior under the
   measured share scatter (larger for lines that rotors share) adds to the
   uncertainty, so an ambiguous count shows as a larger sigma.
8. Uncertainty: centroid noise (per-bin periodogram variance) plus a floor
   ``rel_floor`` per measurement, inflated by the scatter over harmonics (Birge
   ratio), plus the placement of lines that share a cluster.
9. I/Q fit (``refine``, on by default): every CPI with an estimate is refitted by
   least squares on its samples (:mod:`microdoppler.rotors.fit`): each of the M rotors
   is a harmonic series in its own phase with a speed and a rate of change, all
   harmonics sharing them, started from the lines of steps 5-7 (every composition of
   the M rotors on them). Fitting every rotor removes the rotor-count choice of step
   7; a rotor whose lines coincide with another's (too weak to be its own) turns
   with the strongest line and its ambiguity adds to the uncertainty. Where no fit
   stays near the lines, the periodogram's estimate stands.
10. Order (``order=True``, :mod:`microdoppler.rotors.order`): which comb the lines
    are (blade-passing or rotation-rate family, folded Doppler, sub- and
    super-harmonics), judged by a line likelihood and physics (the blade flash's
    Doppler extent against ``blade_length_m``, tip speed); alternatives and their
    doubt go into ``info["order"]``, the uncertainties and the store.
11. Departures (with step 10): a CPI whose mean speed departs from the median of its
    valid neighbours (up to two on either side) by more than :attr:`smear_rel` of it,
    more than the rotor group's speed changes in two hops (``max_step_rel``), read a
    comb its neighbours do not (a line at 5/4 or 3/2 of theirs); it keeps its value,
    and its uncertainties include the departure (:func:`departure_sigma`).

A flight needs ``min_cpis`` CPIs whose comb shows two or more harmonic orders (a lone
mirror pair can be clutter or birds), unless the blades' physics shows one order only
(:func:`one_order_visible`: the second blade-passing harmonic beyond the blade
flash's Doppler extent), the band can hold one order's mirror pair only
(:func:`second_order_folds`: the second order's far line beyond 0.49 PRF), or the
second order would stand under ``pair_snr_db`` (``lone_level``: the first pair's
median level over the floor, :func:`first_pair_db`, plus the thin-wire blade's second
harmonic relative to its first, :func:`second_order_rel_db`) or, for a blade extent
that is not known, would show in as few CPIs as it did with probability
``lone_p_min`` or more (:func:`second_order_absence_p`);
``info["lone_pair"]`` says which, and the pair is needed in ``min_cpis`` CPIs and in
half of them at least; otherwise there is no estimate and ``reason`` says why. CPIs
without a visible pair are NaN; speeds outside ``min_rev_s`` to ``max_rev_s`` are
dropped.

Accuracy is measured by ``benchmarks/eval_rotorspeed.py`` (its numbers:
``docs/experiments.md``). The periodogram's lines alone (steps 1-8, ``herm-pairs/1``)
have a tail from the rotor count per merged line: rotors within a bin of each other
whose speeds spread by 1-5 % within a 0.56 s CPI merge and interfere, and a merged
line's power tells its rotor count only to +-0.1 of the group's; step 9 removes most
of it.

Motor identity: the radar cannot tell which rotor is which, so the columns of
``speeds_rev_s`` are ranks (ascending speed in every CPI), not physical motors.

Storage (flight-zarr/1): :meth:`RotorEstimate.to_motor_log` gives ``motors/time_s``
(CPI centres) and ``motors/rpm`` [n_log, n_motors] (the CPIs with an estimate). A motor
log holds speeds at instants, the radar measures each CPI's window^2-weighted mean, and
the curve a twin drives its rotors with (:mod:`microdoppler.rotors.sampling`: a natural cubic
spline through the rows) smooths the curvature of a speed history: through the CPI
means themselves its CPI means are off by ~0.08 of the second difference (up to ~1 %
on manoeuvres). The rows are therefore the spline's nodes whose CPI means equal the
estimates (:func:`instants_from_cpi_means`); ``cpi_means=True`` gives the estimates.
:meth:`RotorEstimate.store_attrs` gives the group attributes ``motors_source:
"radar"`` and ``motors_radar`` (method, settings, the per-row one-sigma ``rpm_std``
[rev/min], pair and line counts), which flight-zarr/1 preserves ("other attributes
may be present"); the format has no place for extra arrays.
"""

from __future__ import annotations

import itertools
from dataclasses import asdict, dataclass, field, is_dataclass, replace

import numpy as np
from scipy.ndimage import maximum_filter1d
from scipy.signal import find_peaks

from ..configfields import check_ranges, knob
from ..io.flightzarr import Flight
from ..io.motorlog import MotorLog
from .fit import FitConfig, refine_cpi
from .sampling import log_curve
from ..spectra.floor import FLOOR_PERCENTILE, FLOOR_STEP_BINS, FLOOR_WINDOW_BINS, local_floor_db
from ..spectra.periodogram import window
from ..spectra.snr import body_doppler_hz
from ..spectra.spectrogram import PAPER_WINDOW_S, SpectrogramConfig, nearest_power_of_two, spectrogram

#: identifies the method (and its version) in stored attributes: the periodogram's
#: lines alone, or refined by least squares on the I/Q (step 9)
METHOD_LINES = "herm-pairs/1"
METHOD = "herm-pairs+iq-fit/2"


@dataclass(frozen=True)
class RotorSpeedConfig:
    """Settings of :func:`estimate_rotor_speeds` (the module docstring's steps).

    The fields from ``log_step`` on are the method's fixed settings, not knobs: none has
    a physical value a user would set per radar or drone; each is measured through the
    estimator's accuracy (``benchmarks/eval_rotorspeed.py``), how it was set is in
    ``docs/experiments.md``, and each field's description says what it is. The local
    floor's settings are ``microdoppler.spectra.floor``'s (``FLOOR_*``). Derived:
    :attr:`smear_rel`.

    Parameters
    ----------
    min_rev_s, max_rev_s : float
        Plausible rotor speeds [rev/s]: the paper's 40-250 Hz (§II) widened by a
        margin on both sides; drones of any size 20-400 rev/s; a speed outside is no rotor's.
    n_harmonics : int
        Highest harmonic order examined (steps 3, 6), >= 1.
    pair_snr_db : float
        Both lines of a visible pair stand this far over the local noise floor [dB]:
        a periodogram bin of noise alone has exponentially distributed power, so it
        exceeds 10 dB over its mean with probability exp(-10), both lines of a pair
        with ~exp(-20).
    clutter_guard_hz : float
        Dopplers within this of 0 Hz are masked as stationary clutter [Hz] (wider than
        the paper's 15 Hz high-pass).
    body_search_hz : float
        Search half-width of the centre of symmetry around the track's Doppler [Hz]:
        the track's radial-velocity error it tolerates, 20 Hz = 2.2 m/s at 1.35 GHz.
    max_step_rel : float
        Largest relative change of the rotor group's speed from one CPI to the next
        (one hop, n_fft / 2 pulses; step 4); a line smears over twice this within a
        CPI (:attr:`smear_rel`).
    min_cpis : int
        A flight needs this many CPIs whose comb shows two or more harmonic orders
        (a lone mirror pair can be clutter or birds; the negatives of
        eval_rotorspeed.py, Minis and birds relabelled as drones, get none).
    refine : bool
        Step 9: refit every CPI with an estimate by least squares on its I/Q
        (``microdoppler.rotors.fit``, settings ``fit``); False keeps the periodogram's
        estimate (``herm-pairs/1``), which is less accurate.
    fit : FitConfig
        Settings of the least-squares refinement.
    lone_level : bool
        A lone pair is also the comb where the second blade-passing harmonic, at the
        level the thin-wire blade gives it relative to the first pair's median level
        (``second_order_rel_db``, ``first_pair_db``), would stand under
        ``pair_snr_db`` (``info["lone_pair"]`` says so); False: only where the blade
        flash ends short of it or the band folds it.
    lone_p_min : float
        With ``lone_level``, a lone pair is the comb also where the second order's
        absence is not improbable for a thin-wire blade of unknown extent: the
        probability of seeing it in no more CPIs than it was, averaged over kappa in
        ``extent_range`` (``second_order_absence_p``), is at least ``lone_p_min``;
        0 turns this off (only the largest level over kappa counts). Over the whole
        rate range only: the order check's re-measurements in a narrowed range set it
        to 0 (there a smeared line's chance pair would pass).

    See Also
    --------
    estimate_rotor_speeds

    Examples
    --------
    >>> from microdoppler.rotors import RotorSpeedConfig
    >>> cfg = RotorSpeedConfig(refine=False)
    >>> cfg.pair_snr_db, cfg.smear_rel
    (10.0, 0.12)
    """

    min_rev_s: float = 20.0
    max_rev_s: float = 400.0
    n_harmonics: int = 10
    pair_snr_db: float = 10.0
    clutter_guard_hz: float = 20.0
    body_search_hz: float = 20.0
    max_step_rel: float = 0.06
    min_cpis: int = 3
    refine: bool = True
    fit: FitConfig = field(default_factory=FitConfig)
    lone_level: bool = True
    lone_p_min: float = 0.05
    log_step: float = knob(
        0.005, "Relative width of a cell of the Viterbi speed grid (step 4).", exclusive_minimum=0, config=False
    )
    line_prominence_db: float = knob(6.0, "Prominence of a spectral line [dB] (steps 1, 5-6).", minimum=0, config=False)
    group_ratio: float = knob(
        1.5,
        "Rotors are searched within this factor of the tracked group speed: under 2 so that a rotor's second "
        "harmonic stays outside the search (step 4).",
        exclusive_minimum=1,
        config=False,
    )
    step_penalty_db: float = knob(
        0.5, "Viterbi penalty per ``log_step`` speed step [dB of evidence] (step 4).", minimum=0, config=False
    )
    noise_db: float = knob(
        3.0,
        "The outermost lines' regions end where the spectrum falls to ``noise_db`` over the floor or "
        "``line_range_db`` below the line's peak [dB] (step 5).",
        config=False,
    )
    line_range_db: float = knob(30.0, "See ``noise_db`` [dB].", exclusive_minimum=0, config=False)
    n_fft_min: int = knob(
        4096,
        "The shortest default CPI [pulses]: the paper's STFT length (see ``n_fft`` of :func:`estimate_rotor_speeds`).",
        minimum=64,
        config=False,
    )
    n_measure: int = knob(
        4, "Harmonics (from the lowest) at which each cluster's centroid is measured (step 5).", minimum=1, config=False
    )
    min_share: float = knob(
        0.06,
        "A cluster with under this share of the group's power is merged away (step 5).",
        minimum=0,
        maximum=1,
        config=False,
    )
    power_share_sd: float = knob(
        0.06,
        "Rotor counts (step 7): the spread of a power share used to pick the counts.",
        exclusive_minimum=0,
        config=False,
    )
    split_cost: float = knob(
        10.0,
        "Rotor counts (step 7): the cost [in -2 log-likelihood] of a resolved line left without a rotor.",
        minimum=0,
        config=False,
    )
    pattern_sd: float = knob(
        0.02, "Rotor counts (step 7): the spread of the relative-speed pattern.", exclusive_minimum=0, config=False
    )
    pattern_cpis: int = knob(
        8, "Rotor counts (step 7): the CPIs on either side that give the pattern.", minimum=0, config=False
    )
    spread_share_sd: float = knob(
        0.075,
        "The uncertainty of the mean speed from the rotor counts (step 7): the share of a line of k rotors has "
        "variance ``spread_share_sd``^2 + ``spread_interference_sd``^2 k (k - 1) / 2 (measured scatter of the "
        "shares on emulated flights).",
        exclusive_minimum=0,
        config=False,
    )
    spread_interference_sd: float = knob(0.10, "See ``spread_share_sd``.", minimum=0, config=False)
    rel_floor: float = knob(
        0.008, "Relative uncertainty floor of one centroid measurement (step 8).", minimum=0, config=False
    )
    block_cpis: int = knob(
        64, "CPIs per STFT block (memory only: the result does not depend on it).", minimum=1, config=False
    )
    overlap_variance_factor: float = knob(
        2.0,
        "Variance of the mean of 50 %-overlapping CPIs' errors over that of independent ones (neighbours share "
        "half their pulses: correlation 0.5 with a flat window, less with Blackman-Harris; 1 + 2 x 0.5 bounds "
        "it; :func:`recording_means`).",
        exclusive_minimum=0,
        config=False,
    )

    def __post_init__(self):
        check_ranges(self, "rotors.speed", all_fields=True)  # the fixed settings' ranges (config=False knobs)
        if not 0 < self.min_rev_s < self.max_rev_s:
            raise ValueError(f"min_rev_s={self.min_rev_s}, max_rev_s={self.max_rev_s} must satisfy 0 < min < max")
        if self.n_harmonics < 1:
            raise ValueError(f"n_harmonics={self.n_harmonics} must be >= 1")
        if not self.pair_snr_db > 0:
            raise ValueError(f"pair_snr_db={self.pair_snr_db} must be > 0")
        if self.clutter_guard_hz < 0 or self.body_search_hz < 0:
            raise ValueError(
                f"clutter_guard_hz={self.clutter_guard_hz} and body_search_hz={self.body_search_hz} must be >= 0"
            )
        if not 0 < self.max_step_rel < 0.5:
            raise ValueError(f"max_step_rel={self.max_step_rel} must be in (0, 0.5)")
        if self.min_cpis < 1:
            raise ValueError(f"min_cpis={self.min_cpis} must be >= 1")
        if not 0 <= self.lone_p_min < 1:
            raise ValueError(f"lone_p_min={self.lone_p_min} must be in [0, 1)")

    @property
    def smear_rel(self) -> float:
        """Largest relative extent of a line beyond its peak: the speed change over one
        CPI, i.e. two hops of ``max_step_rel`` (50 % overlap)."""
        return 2 * self.max_step_rel


@dataclass
class RotorEstimate:
    """Rotor speeds estimated from a flight's HERM lines.

    Attributes
    ----------
    flight_id : str
    time_s : ndarray, float64 [n_cpi]
        CPI centres [s] on the radar clock.
    speeds_rev_s : ndarray, float64 [n_cpi, n_motors]
        Rotor speeds [rev/s], ascending in every CPI (ranks, not physical motors;
        a line shared by several rotors repeats); NaN where no pair is visible.
    speeds_std_rev_s : ndarray, float64 [n_cpi, n_motors]
        Uncertainty of each speed [rev/s]: with the I/Q fit, 95 % of the errors lie
        within 2 of it (``microdoppler.rotors.fit``, its docstring).
    common_rev_s, common_std_rev_s : ndarray, float64 [n_cpi]
        Mean rotor speed and its uncertainty [rev/s] (what can be said where the
        rotors are not separated).
    n_pairs : ndarray, int [n_cpi]
        Harmonic orders n with a visible sideband pair (both lines above the floor).
    n_lines : ndarray, int [n_cpi]
        Distinct rotor lines separated (``n_motors`` where every rotor is resolved).
    body_hz : ndarray, float64 [n_cpi]
        Centre of symmetry of the sidebands (body Doppler) [Hz].
    n_motors, n_blades : int
    n_fft : int
    reason : str or None
        Why there is no estimate (None when there is one).
    info : dict
        Settings and counts (JSON-serialisable).
    balance : ndarray, float64 [n_cpi] or None
        The I/Q fit's power balance per CPI (its weakest rotor's power over its
        strongest's, ``microdoppler.rotors.fit.CpiFit``); NaN where the CPI was not
        refitted; None without step 9. Low balance: the rotors' composition on the lines
        is in doubt, and the uncertainty says so.

    See Also
    --------
    estimate_rotor_speeds

    Examples
    --------
    >>> import numpy as np
    >>> from microdoppler.emulator import FlightSpec, emulate_flight
    >>> from microdoppler.rotors import RotorSpeedConfig, estimate_rotor_speeds
    >>> flight, _ = emulate_flight(FlightSpec("demo", "drone", drone_model="inspire2", duration_s=2.0,
    ...                                       mean_range_m=600.0, path="straight", snr_db=40.0, seed=1))
    >>> est = estimate_rotor_speeds(flight, config=RotorSpeedConfig(refine=False), order=False)
    >>> est.ok, est.speeds_rev_s.shape, int(est.valid.sum())
    (True, (6, 4), 6)
    >>> log = est.to_motor_log()
    >>> log.n_motors
    4
    """

    flight_id: str
    time_s: np.ndarray
    speeds_rev_s: np.ndarray
    speeds_std_rev_s: np.ndarray
    common_rev_s: np.ndarray
    common_std_rev_s: np.ndarray
    n_pairs: np.ndarray
    n_lines: np.ndarray
    body_hz: np.ndarray
    n_motors: int
    n_blades: int
    n_fft: int
    reason: str | None = None
    info: dict = field(default_factory=dict)
    balance: np.ndarray | None = None

    @property
    def ok(self) -> bool:
        """True when the flight has an estimate."""
        return self.reason is None

    @property
    def valid(self) -> np.ndarray:
        """bool [n_cpi]: CPIs with an estimate."""
        return np.isfinite(self.common_rev_s)

    @property
    def separated(self) -> np.ndarray:
        """bool [n_cpi]: CPIs where every rotor has its own line."""
        return self.valid & (self.n_lines >= self.n_motors)

    @property
    def line_spacing_hz(self) -> np.ndarray:
        """Mean HERM line spacing B f [Hz], float64 [n_cpi]."""
        return self.n_blades * self.common_rev_s

    def to_motor_log(self, *, per_motor: bool = True, cpi_means: bool = False) -> MotorLog:
        """The estimate as a :class:`~microdoppler.io.MotorLog` (``motors/time_s``, ``motors/rpm``).

        Rows are the CPIs with an estimate. ``per_motor`` (default) gives each
        rank's speed; otherwise every column holds the mean rotor speed. The speeds
        are instants (``instants_from_cpi_means``: a natural cubic spline through
        the rows has the estimates as its CPI means) unless ``cpi_means``.

        Raises
        ------
        ValueError
            Without an estimate (``reason`` says why) or with fewer than 2 rows.
        """
        if not self.ok:
            raise ValueError(f"{self.flight_id}: no rotor-speed estimate: {self.reason}")
        v = self.valid
        if v.sum() < 2:
            raise ValueError(f"{self.flight_id}: {int(v.sum())} CPI with an estimate; a motor log needs 2 rows")
        rev = self.speeds_rev_s[v] if per_motor else np.repeat(self.common_rev_s[v, None], self.n_motors, axis=1)
        t = self.time_s[v].astype(np.float64)
        if not cpi_means:
            rev = instants_from_cpi_means(t, rev, self.n_fft, float(self.info["prf_hz"]))
        return MotorLog(
            t, (rev * 60.0).astype(np.float32), f"{self.flight_id}: radar ({self.info.get('method', METHOD)})"
        )

    def store_attrs(self, *, per_motor: bool = True, cpi_means: bool = False) -> dict:
        """Group attributes that go with :meth:`to_motor_log` in a flight-zarr/1 store:
        ``motors_source = "radar"`` and ``motors_radar`` (JSON: method, settings,
        ``rpm_std`` [n_log][n_motors] rev/min, what the rows are (``rows``, as
        ``to_motor_log(cpi_means=...)``), ``n_pairs``, ``n_lines`` and the I/Q fit's
        ``balance`` per row)."""
        v = self.valid
        std = self.speeds_std_rev_s[v] if per_motor else np.repeat(self.common_std_rev_s[v, None], self.n_motors, 1)
        # the I/Q fit's sigma is calibrated (95 % within 2 sigma); the lines' alone is not
        fitted = (
            {}
            if self.balance is None
            else {"balance": [round(float(b), 3) if np.isfinite(b) else None for b in self.balance[v]]}
        )
        sigma = (
            "the CPI mean's uncertainty (on held-out emulated flights 95-96 % of errors within 2 rpm_std "
            "where n_pairs >= 2, 90-98 % where n_pairs = 1)"
            if fitted
            else "the CPI mean's uncertainty from the periodogram's lines"
        )
        return {
            "motors_source": "radar",
            "motors_radar": {
                "method": self.info.get("method", METHOD),
                "n_fft": int(self.n_fft),
                "columns": "ascending speed per row (rotor ranks, not physical motors)"
                if per_motor
                else "mean rotor speed in every column",
                "rpm_std": np.round(std * 60.0, 1).tolist(),
                **_mean_attrs(self, per_motor),
                "rows": (
                    "the estimates (window^2-weighted CPI means)"
                    if cpi_means
                    else "cubic-spline nodes whose window^2-weighted CPI means equal the estimates"
                )
                + "; rpm_std is "
                + sigma,
                "n_pairs": self.n_pairs[v].astype(int).tolist(),
                "n_lines": self.n_lines[v].astype(int).tolist(),
                **fitted,
                **_order_attrs(self),
                "settings": self.info.get("settings", {}),
            },
        }

    def with_flight(self, flight: Flight, *, per_motor: bool = True, cpi_means: bool = False) -> Flight:
        """A copy of ``flight`` carrying this estimate as its motor log (for
        :func:`microdoppler.io.write_flight`)."""
        log = self.to_motor_log(per_motor=per_motor, cpi_means=cpi_means)
        attrs = {**flight.attrs, **self.store_attrs(per_motor=per_motor, cpi_means=cpi_means)}
        return replace(flight, attrs=attrs, motors_time_s=log.time_s, motors_rpm=log.rpm)

    def summary(self) -> str:
        """One line: CPIs with an estimate, the method stored with the speeds (and, where
        it is the lines' alone after an I/Q fit at another order, why), mean speed, pairs
        (and why a lone pair was
        read as the comb; how many CPIs depart from their neighbours; the CPI where the
        default's gave no estimate), or the reason."""
        if not self.ok:
            return f"{self.flight_id}: no estimate: {self.reason}"
        v = self.valid
        lone = self.info.get("lone_pair")
        dep = int(self.info.get("n_cpi_departing", 0))
        method = self.info.get("method", METHOD)
        remeasured = (self.info.get("order") or {}).get("remeasured", "")
        fallback = (
            f" (the lines alone: the I/Q fit ran at another order and its speeds were not kept; {remeasured})"
            if method == METHOD_LINES and remeasured.startswith("the lines'")
            else ""
        )
        return (
            f"{self.flight_id}: {int(v.sum())} of {len(v)} CPIs, method {method}{fallback}, mean rotor speed "
            f"{np.nanmean(self.common_rev_s):.1f} rev/s, median {np.median(self.n_pairs[v]):.0f} pairs, "
            f"{int(self.separated.sum())} CPIs with every rotor separated"
            + (f"; a lone pair read as the comb: {lone}" if lone else "")
            + (
                f"; {dep} CPIs depart from both neighbours by over "
                f"{100 * self.info.get('departure_rel', 0):.0f} % (their rpm_std includes it)"
                if dep
                else ""
            )
            + (f"; CPI {self.info['cpi']}" if "cpi" in self.info else "")
        )


def _mean_attrs(est, per_motor: bool) -> dict:
    """``motors_radar`` attributes of the recording means (:func:`recording_means`)."""
    mean, std = recording_means(est)
    if not per_motor:  # every column the mean rotor speed: the ranks' mean; its sigma the ranks'
        # mean sigma (their errors share the comb's and the method's bias: not independent)
        ok = np.isfinite(mean)
        if not ok.any():
            return {}
        m, s = float(np.mean(mean[ok])), float(np.mean(std[ok]))
        mean, std = np.full(len(mean), m), np.full(len(mean), s)
    out = {
        "mean_rpm": [None if not np.isfinite(v) else round(float(v) * 60.0, 1) for v in mean],
        "mean_rpm_std": [None if not np.isfinite(v) else round(float(v) * 60.0, 1) for v in std],
        "mean_rpm_std_is": "the one-sigma uncertainty of each column's mean over the recording: the CPIs' "
        "sigma or scatter (overlap included), the mean minus the median, and the difference between the methods "
        "(microdoppler.rotors.speed.recording_means)",
    }
    if est.info.get("method_diff_rev_s") is not None:
        out["method_diff_rpm"] = [round(float(d) * 60.0, 1) for d in est.info["method_diff_rev_s"]]
    return out


def _order_attrs(est) -> dict:
    from .order import order_attrs

    return order_attrs(est)


def _no_estimate(flight_id, n_cpi, t, n_motors, n_blades, n_fft, reason, info=None) -> RotorEstimate:
    nan = np.full(n_cpi, np.nan)
    return RotorEstimate(
        flight_id,
        t,
        np.full((n_cpi, n_motors), np.nan),
        np.full((n_cpi, n_motors), np.nan),
        nan.copy(),
        nan.copy(),
        np.zeros(n_cpi, int),
        np.zeros(n_cpi, int),
        nan.copy(),
        int(n_motors),
        int(n_blades),
        int(n_fft),
        reason,
        dict(info or {}),
    )


def _parabolic(y_m1, y0, y_p1) -> float:
    den = y_m1 - 2 * y0 + y_p1
    return float(np.clip(0.5 * (y_m1 - y_p1) / den, -0.5, 0.5)) if den < 0 else 0.0


def _at(arr: np.ndarray, x: np.ndarray) -> np.ndarray:
    """max(arr[floor x], arr[ceil x]) at fractional indices ``x``; NaN outside."""
    n = len(arr)
    out = np.full(np.shape(x), np.nan)
    ok = (x >= 0) & (x <= n - 1)
    xi = x[ok]
    out[ok] = np.maximum(arr[np.floor(xi).astype(int)], arr[np.ceil(xi).astype(int)])
    return out


@dataclass
class _Cpi:
    """One CPI: spectrum in dB over the local floor (masked bins -100, float32
    [n_fft]) and the centre of symmetry of its sidebands [fractional bin]."""

    z: np.ndarray
    centre: float


def estimate_rotor_speeds(
    flight: Flight,
    *,
    n_fft: int | None = None,
    n_motors: int | None = None,
    n_blades: int | None = None,
    config: RotorSpeedConfig | None = None,
    progress=None,
    order: bool = True,
) -> RotorEstimate:
    """Estimate each rotor's speed over time from the flight's HERM lines.

    Parameters
    ----------
    flight : Flight
        A flight-zarr/1 flight (its motor log, if any, is ignored).
    n_fft : int, optional
        CPI length [pulses], 50 % overlap. Default: the power of two nearest the
        paper's CPI in time (``PAPER_WINDOW_S``, 0.56 s) x PRF, as the spectrogram's
        default, but at least ``n_fft_min`` (4096, the paper's STFT): 8192 at 10.3-20.7
        kHz. Shorter CPIs give coarser bins (4096 pulses at 14-19 kHz: 4 % of a 2-blade
        rotor's first line at 44 rev/s) and biased speeds (the trade-off measured:
        ``docs/experiments.md``). Where the longer default CPI gives no
        estimate (rotor speeds changing within it smear the lines: a flying drone at
        1.3 GHz and 19 kHz), the estimate is made at 4096 pulses and ``info["cpi"]``
        says so.
    n_motors, n_blades : int, optional
        Rotor count and blades per rotor; default the flight's ``n_motors`` and
        ``n_blades`` attributes.
    config : RotorSpeedConfig, optional
        Method settings (see the module docstring).
    progress : callable(done, total), optional
        Called during the I/Q fit (step 9, ~0.35 s per CPI) every 64 CPIs and at its end.
    order : bool
        Check the comb's harmonic order (``microdoppler.rotors.order.resolve_order``:
        unequal blades, folded Doppler, sub- and super-harmonics; alternatives and their
        doubt in ``info["order"]`` and the uncertainties). False: the comb as found.

    Returns
    -------
    RotorEstimate
        Per-CPI speeds with uncertainties; ``reason`` set (and every speed NaN) when
        the flight shows no sideband pair, is not a drone or is shorter than a CPI.

    Raises
    ------
    ValueError
        When ``n_fft`` is odd or below 64, or ``n_motors`` below 1.

    See Also
    --------
    RotorEstimate, RotorSpeedConfig, microdoppler.rotors.resample

    Examples
    --------
    A 2 s emulated Inspire 2 at 600 m; without the I/Q fit and the order check
    (``refine=False``, ``order=False``) the estimate takes a fraction of a second:

    >>> import numpy as np
    >>> from microdoppler.emulator import FlightSpec, emulate_flight
    >>> from microdoppler.rotors import RotorSpeedConfig, estimate_rotor_speeds
    >>> flight, _ = emulate_flight(FlightSpec("demo", "drone", drone_model="inspire2", duration_s=2.0,
    ...                                       mean_range_m=600.0, path="straight", snr_db=40.0, seed=1))
    >>> est = estimate_rotor_speeds(flight, config=RotorSpeedConfig(refine=False), order=False)
    >>> est.ok, est.time_s.shape, est.speeds_rev_s.shape
    (True, (6,), (6, 4))
    >>> logged_rev_s = float(np.median(flight.motors_rpm)) / 60
    >>> bool(abs(np.nanmedian(est.common_rev_s) / logged_rev_s - 1) < 0.05)
    True
    """
    cfg = config or RotorSpeedConfig()
    attrs = flight.attrs
    fid = str(attrs.get("flight_id", ""))
    prf = float(flight.prf_hz)
    M = int(n_motors if n_motors is not None else attrs.get("n_motors", 4))
    B = n_blades if n_blades is not None else attrs.get("n_blades")
    if n_fft is None:
        n_fft = max(cfg.n_fft_min, nearest_power_of_two(PAPER_WINDOW_S * prf))
        if n_fft > cfg.n_fft_min:
            # a longer CPI resolves slow rotors' lines; where their speeds change within
            # it the lines smear below the pair threshold: then the paper's 4096 pulses
            kw = dict(n_motors=n_motors, n_blades=n_blades, config=config, progress=progress, order=order)
            est = estimate_rotor_speeds(flight, n_fft=n_fft, **kw)
            if est.ok:
                return est
            short = estimate_rotor_speeds(flight, n_fft=cfg.n_fft_min, **kw)
            if not short.ok:
                return est
            short.info["cpi"] = (
                f"{cfg.n_fft_min} pulses: the default CPI of {n_fft} ({n_fft / prf:.2f} s) gave no estimate ({est.reason})"
            )
            return short
    if n_fft < 64 or n_fft % 2:
        raise ValueError(f"n_fft={n_fft} must be an even integer >= 64")
    if M < 1:
        raise ValueError(f"n_motors={M} must be >= 1")
    hop = n_fft // 2
    n_pulses = len(flight.iq)
    n_cpi = 1 + (n_pulses - n_fft) // hop if n_pulses >= n_fft else 0
    t = (np.arange(n_cpi) * hop + n_fft / 2) / prf
    info = {
        "settings": {
            k: (asdict(v) if is_dataclass(v) else v)
            for k, v in ((k, getattr(cfg, k)) for k in cfg.__dataclass_fields__)
        },
        "n_cpi": int(n_cpi),
        "prf_hz": prf,
    }
    target = attrs.get("target", "drone")
    if target != "drone":
        return _no_estimate(fid, n_cpi, t, M, B or 0, n_fft, f"target is {target!r}: no rotors", info)
    if B is None or int(B) < 1:
        return _no_estimate(fid, n_cpi, t, M, 0, n_fft, "blades per rotor unknown (no n_blades attribute)", info)
    B = int(B)
    if n_cpi == 0:
        return _no_estimate(
            fid, 0, t, M, B, n_fft, f"flight shorter than one CPI ({n_pulses} pulses < n_fft={n_fft})", info
        )

    bin_hz = prf / n_fft
    N = cfg.n_harmonics
    # fine speed grid: one step moves harmonic N by 1/4 bin
    step = 0.25 * bin_hz / (N * B)
    fgrid = np.arange(cfg.min_rev_s, cfg.max_rev_s + step, step)
    # Viterbi grid: log cells of log_step; cell k covers fgrid[cell_start[k]:cell_start[k + 1]]
    n_states = int(np.ceil(np.log(cfg.max_rev_s / cfg.min_rev_s) / cfg.log_step)) + 1
    cell_lo = cfg.min_rev_s * np.exp((np.arange(n_states) - 0.5) * cfg.log_step)
    cell_start = np.maximum.accumulate(np.clip(np.searchsorted(fgrid, cell_lo), 0, len(fgrid) - 1))
    spec_cfg = SpectrogramConfig(n_fft=n_fft, overlap=0.5, highpass_hz=0.0, n_bins=0, tile_timesteps=1)
    f_track = body_doppler_hz(flight.track_time_s, flight.track_radial_velocity_mps, flight.wavelength_m, t)
    cpis: list[_Cpi] = []
    emis = np.zeros((n_cpi, n_states))
    f_hz = None
    for i0 in range(0, n_cpi, cfg.block_cpis):
        i1 = min(n_cpi, i0 + cfg.block_cpis)
        seg = np.asarray(flight.iq[i0 * hop : (i1 - 1) * hop + n_fft])
        sp = spectrogram(seg, prf, spec_cfg)
        f_hz = sp.doppler_hz.astype(np.float64)
        z = sp.power_db - local_floor_db(
            sp.power_db, window_bins=FLOOR_WINDOW_BINS, step_bins=FLOOR_STEP_BINS, percentile=FLOOR_PERCENTILE
        )
        masked = np.abs(f_hz) < cfg.clutter_guard_hz
        for k in range(i1 - i0):
            zk = np.where(masked, -100.0, z[k]).astype(np.float64)
            zpk1, zpk2 = _line_evidence(zk, cfg)
            centre = _centre(zk, zpk1, f_track[i0 + k], f_hz, B, cfg)
            _, _, R = _evidence(zpk1, zpk2, centre, fgrid, B, bin_hz, cfg)
            emis[i0 + k] = np.maximum.reduceat(R, cell_start)
            cpis.append(_Cpi(zk.astype(np.float32), centre))
    # continuity prior: Viterbi over the log-speed cells
    path = _viterbi(emis, int(np.ceil(cfg.max_step_rel / cfg.log_step)), cfg.step_penalty_db)
    f_path = cfg.min_rev_s * np.exp(path * cfg.log_step)

    speeds = np.full((n_cpi, M), np.nan)
    sds = np.full((n_cpi, M), np.nan)
    common = np.full(n_cpi, np.nan)
    common_sd = np.full(n_cpi, np.nan)
    n_pairs = np.zeros(n_cpi, int)
    n_lines = np.zeros(n_cpi, int)
    body = f_hz[0] + np.array([c.centre for c in cpis]) * bin_hz
    lines = [_rotors(c, f_path[i], fgrid, cfg, B, M, bin_hz) for i, c in enumerate(cpis)]
    for i, alloc in enumerate(_allocate(lines, M, cfg)):
        if alloc is None:
            continue
        cnt, common[i], var_alloc = alloc
        speeds[i], sds[i] = lines[i].rotors(cnt)
        common_sd[i] = np.sqrt(lines[i].mean_var(cnt) + var_alloc)
        n_pairs[i] = lines[i].n_pairs
        n_lines[i] = sum(min(len(m), int(k)) for m, k in zip(lines[i].members, cnt))

    def plausible():
        # a rotor speed outside the plausible range is not one
        out = ~((common >= cfg.min_rev_s) & (common <= cfg.max_rev_s))
        speeds[out], sds[out], common[out], common_sd[out] = np.nan, np.nan, np.nan, np.nan
        n_pairs[out], n_lines[out] = 0, 0
        return int(np.isfinite(common).sum()), int((np.isfinite(common) & (n_pairs >= 2)).sum())

    n_ok, n_comb = plausible()
    # a lone pair is an estimate only where the blades' physics shows no more (the
    # second blade-passing harmonic beyond the blade flash's Doppler extent) or the band
    # cannot (its mirror pair folded), and only where it persists, in half the CPIs at
    # least (a rotor's first pair stands in most CPIs; an intermittent pair at the speed
    # range's floor is not its comb)
    few = n_comb < cfg.min_cpis and n_ok >= max(cfg.min_cpis, 0.5 * n_cpi)
    lone_why = None
    second_db = None
    if few and one_order_visible(flight, B):
        lone_why = "extent"
    elif few and second_order_folds(common, body, B, prf):
        lone_why = "folded"
    elif few and cfg.lone_level:
        rel_db = second_order_rel_db(flight, B)
        first = first_pair_db(cpis, speeds, B, bin_hz)
        if rel_db is not None and np.isfinite(first).any():
            second_db = float(np.nanmedian(first)) + rel_db
            if second_db < cfg.pair_snr_db:
                lone_why = "level"
            elif cfg.lone_p_min > 0:
                absence_p = second_order_absence_p(flight, B, float(np.nanmedian(first)), n_comb, n_ok, cfg.pair_snr_db)
                if absence_p is not None and absence_p >= cfg.lone_p_min:
                    lone_why = "likely"
    lone = lone_why is not None
    n_refined = 0
    balance = None
    if cfg.refine and n_ok > 0 and (n_comb >= cfg.min_cpis or lone):  # step 9 only where there is an estimate
        balance = np.full(n_cpi, np.nan)
        n_refined = _refine(
            flight, cfg, speeds, sds, common, common_sd, body, t, hop, n_fft, B, M, n_pairs, progress, balance
        )
        n_ok, n_comb = plausible()
        balance[~np.isfinite(common)] = np.nan
    info.update(
        {
            "method": METHOD if cfg.refine else METHOD_LINES,
            "n_cpi_refined": int(n_refined),
            "n_cpi_estimated": n_ok,
            "n_cpi_comb": n_comb,
            "n_cpi_separated": int((np.isfinite(common) & (n_lines >= M)).sum()),
        }
    )
    if lone_why == "extent":
        info["lone_pair"] = (
            f"{n_ok} of {n_cpi} CPIs show one sideband pair and {n_comb} two or more harmonic "
            f"orders: the blade flash's Doppler extent (blade_length_m "
            f"{float(attrs['blade_length_m']):g} m at {flight.wavelength_m:.4g} m) holds one "
            f"blade-passing harmonic only"
        )
    elif lone_why == "level":
        info["lone_pair"] = (
            f"{n_ok} of {n_cpi} CPIs show one sideband pair and {n_comb} two or more harmonic "
            f"orders: the second blade-passing harmonic of a thin-wire blade (blade_length_m "
            f"{float(attrs['blade_length_m']):g} m at {flight.wavelength_m:.4g} m) is expected at "
            f"{second_db:.1f} dB over the floor, under the pair threshold {cfg.pair_snr_db:g} dB"
        )
    elif lone_why == "likely":
        info["lone_pair"] = (
            f"{n_ok} of {n_cpi} CPIs show one sideband pair and {n_comb} two or more harmonic "
            f"orders: a thin-wire blade (blade_length_m {float(attrs['blade_length_m']):g} m at "
            f"{flight.wavelength_m:.4g} m) shows its second blade-passing harmonic that rarely "
            f"with probability {absence_p:.2f} (averaged over its extent; up to {second_db:.1f} dB "
            f"over the floor)"
        )
    elif lone_why == "folded":
        info["lone_pair"] = (
            f"{n_ok} of {n_cpi} CPIs show one sideband pair and {n_comb} two or more harmonic "
            f"orders: the second order's pair lies beyond +-{0.49 * prf:.0f} Hz (PRF {prf:.0f} Hz) "
            f"and folds, so the band holds one mirror pair only"
        )
    reason = None
    if n_ok == 0:
        reason = (
            f"no sideband pair above the noise: 0 of {n_cpi} CPIs show a pair (both lines >= "
            f"{cfg.pair_snr_db:g} dB over the local floor at rotor speeds "
            f"{cfg.min_rev_s:g}-{cfg.max_rev_s:g} rev/s)"
        )
    elif n_comb < cfg.min_cpis and not lone:
        reason = (
            f"no HERM comb: {n_ok} of {n_cpi} CPIs show a sideband pair but {n_comb} show two or more "
            f"harmonic orders (an estimate needs >= {cfg.min_cpis}; a lone mirror pair may be clutter "
            f"or birds)"
        )
    if reason is not None:
        est = _no_estimate(fid, n_cpi, t, M, B, n_fft, reason, info)
        est.n_pairs = n_pairs
    else:
        est = RotorEstimate(
            fid, t, speeds, sds, common, common_sd, n_pairs, n_lines, body, M, B, n_fft, None, info, balance
        )
    if order:  # which comb the lines are, with its doubt (rotors.order)
        from .order import resolve_order

        est = resolve_order(
            flight,
            est,
            cfg,
            rerun=lambda c, n_blades=B: estimate_rotor_speeds(
                flight, n_fft=n_fft, n_motors=M, n_blades=n_blades, config=c, progress=progress, order=False
            ),
        )
        if est.ok:
            departure_sigma(est, cfg.smear_rel)
    return est


def recording_means(est: RotorEstimate, overlap_variance_factor: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Each rotor rank's mean speed over the recording and its one-sigma uncertainty.

    The variance of a rank's mean over its n CPIs joins (a) the larger of the CPIs' own
    (the sum of their squared sigma over n squared) and their scatter about the local
    trend (the mean square of their departures from the running median of five CPIs,
    over n), each times ``overlap_variance_factor`` (overlapping CPIs' errors are
    correlated): ranks exchanged between CPIs scatter more than their sigma says; (b)
    the squared difference between the mean and the median of its CPIs (misread CPIs
    on one side pull the mean, not the median); and (c) the squared difference between
    the methods, the I/Q fit's mean minus the lines' alone over the CPIs both estimated
    (``info["method_diff_rev_s"]``, where both ran): a bias neither sigma holds.

    Parameters
    ----------
    est : RotorEstimate
    overlap_variance_factor : float, optional
        Default: the estimate's setting (``info["settings"]``), else
        :class:`RotorSpeedConfig`'s.

    Returns
    -------
    mean_rev_s, mean_std_rev_s : ndarray, float64 [n_motors]
        Per rank [rev/s]; NaN without an estimate.
    """
    sp, sd = np.asarray(est.speeds_rev_s, float), np.asarray(est.speeds_std_rev_s, float)
    M = sp.shape[1] if sp.ndim == 2 else 0
    mean, std = np.full(M, np.nan), np.full(M, np.nan)
    if not est.ok:
        return mean, std
    diff = est.info.get("method_diff_rev_s")
    if overlap_variance_factor is None:
        overlap_variance_factor = (est.info.get("settings") or {}).get(
            "overlap_variance_factor", RotorSpeedConfig.overlap_variance_factor
        )
    for r in range(M):
        ok = np.isfinite(sp[:, r]) & np.isfinite(sd[:, r]) & (sd[:, r] > 0)
        n = int(ok.sum())
        if n == 0:
            continue
        x, s = sp[ok, r], sd[ok, r]
        mean[r] = float(np.mean(x))
        var = float(np.sum(s**2)) / n**2
        if n >= 5:
            trend = np.array([np.median(x[max(0, i - 2) : i + 3]) for i in range(n)])
            var = max(var, float(np.mean((x - trend) ** 2)) / n)
        var = var * overlap_variance_factor + (mean[r] - float(np.median(x))) ** 2
        if diff is not None and r < len(diff) and diff[r] is not None:
            var += float(diff[r]) ** 2
        std[r] = float(np.sqrt(var))
    return mean, std


def departure_sigma(est: RotorEstimate, rel: float) -> int:
    """Step 11 (in place): where a CPI's mean speed departs from the median of its valid
    neighbours (up to two on either side, at least one on each) by more than ``rel`` of
    that median, the departure d joins its uncertainties in quadrature (the mean's and
    each rotor's). Returns the number of such CPIs (also ``info["n_cpi_departing"]``,
    with ``rel`` in ``info["departure_rel"]``).

    The tool's own motion model lets the group's speed change by ``max_step_rel`` per hop
    (a steady change leaves the median of both sides on the CPI); a larger departure is
    a comb misread in that CPI (at 5/4 or 3/2 of its neighbours, tens of per cent off
    with a sigma of a few) or a change faster than the model allows (a sharp
    manoeuvre estimated right: its sigma grows, its error does not). What the rule
    flags and gains is measured in ``docs/experiments.md``."""
    c = est.common_rev_s
    ok = np.isfinite(c)
    n = 0
    for i in np.flatnonzero(ok):
        before = [j for j in range(max(0, i - 2), i) if ok[j]]
        after = [j for j in range(i + 1, min(len(c), i + 3)) if ok[j]]
        if not before or not after:
            continue  # one side only: a steady change reads as a departure
        m = float(np.median(c[before + after]))
        d = float(c[i] - m)
        if abs(d) > rel * m:
            est.common_std_rev_s[i] = np.hypot(est.common_std_rev_s[i], d)
            est.speeds_std_rev_s[i] = np.hypot(est.speeds_std_rev_s[i], d)
            n += 1
    est.info["n_cpi_departing"] = n
    est.info["departure_rel"] = float(rel)
    return n


def second_order_folds(common_rev_s: np.ndarray, body_hz: np.ndarray, n_blades: int, prf_hz: float) -> bool:
    """Whether the comb's second blade-passing order cannot show as a mirror pair inside
    the band: on the median CPI with an estimate, |body| + 2 B f passes 0.49 PRF (the
    pair search's limit), so one line of that pair folds to the other side of the
    spectrum. A lone pair is then all the band can show of the comb as a mirror pair
    (a 5.8 GHz recording at 2.9 kHz PRF: body +440 Hz, pair at +-672 Hz, the second
    order's upper line at +1784 Hz folds to -1162 Hz); which order it is stays the
    order check's, whose line model folds."""
    ok = np.isfinite(common_rev_s) & np.isfinite(body_hz)
    if not ok.any():
        return False
    reach = np.abs(body_hz[ok]) + 2 * int(n_blades) * common_rev_s[ok]
    return bool(np.median(reach) > 0.49 * float(prf_hz))


def second_order_rel_db(flight, n_blades: int) -> float | None:
    """The second blade-passing harmonic's level relative to the first [dB], the largest
    over the blade flash's extent kappa in :class:`.order.OrderConfig`'s
    ``extent_range``, for the paper's thin-wire blade (eq. 1: scatterers uniform from
    the hub to the tip): harmonic k has the amplitude (1 / x) int_0^x J_k(t) dt =
    (2 / x) sum_j J_(k + 2 j + 1)(x), x = kappa beta, beta = 4 pi L / lambda. Short
    blades at a long wavelength put the second harmonic far down (beta = 5.8, three
    blades: -10 dB at kappa = 1.1; beta = 3.8, two: -11 dB); None without
    ``blade_length_m``. A tip that returns more than the blade's share (a point at the
    tip, J_k(x)) raises it: the rule is the thin wire's, as the synthesis'."""
    rel = _second_over_first(flight, n_blades)
    return None if rel is None else float(np.max(20 * np.log10(rel)))


def _second_over_first(flight, n_blades: int) -> np.ndarray | None:
    """The thin-wire blade's second blade-passing harmonic over its first (amplitude) at
    11 points of kappa over :class:`.order.OrderConfig`'s ``extent_range``; None without
    ``blade_length_m``."""
    from .order import OrderConfig

    L = flight.attrs.get("blade_length_m")
    if L is None or not np.isfinite(float(L)) or float(L) <= 0:
        return None
    beta = 4 * np.pi * float(L) / float(flight.wavelength_m)
    lo, hi = OrderConfig().extent_range
    x = beta * np.linspace(lo, hi, 11)
    B = int(n_blades)
    return np.abs(thin_wire_harmonic(2 * B, x)) / np.maximum(np.abs(thin_wire_harmonic(B, x)), 1e-300)


def second_order_absence_p(
    flight, n_blades: int, first_db: float, n_seen: int, n_cpis: int, threshold_db: float
) -> float | None:
    """How probable it is that a thin-wire comb whose first pair stands ``first_db`` over
    the floor shows its second blade-passing pair (both lines >= ``threshold_db``) in at
    most ``n_seen`` of ``n_cpis`` CPIs: the binomial probability, each CPI's chance the
    pair's two lines both pass (a line of mean power S over unit noise passes T with
    Marcum's Q_1(sqrt(2 S), sqrt(2 T))), averaged over kappa in
    :class:`.order.OrderConfig`'s ``extent_range`` (11 points, uniform), the second
    harmonic's level from :func:`thin_wire_harmonic`. The extent is not known; the mean
    over it is the prior's predictive probability of what was seen. None without
    ``blade_length_m``."""
    from scipy.stats import binom, ncx2

    rel = _second_over_first(flight, n_blades)
    if rel is None or n_cpis < 1:
        return None
    s = 10 ** (first_db / 10) * rel**2
    p_line = ncx2.sf(2 * 10 ** (threshold_db / 10), 2, 2 * s)
    return float(np.mean(binom.cdf(int(n_seen), int(n_cpis), p_line**2)))


def thin_wire_harmonic(k: int, x) -> np.ndarray:
    """Harmonic k's amplitude of a thin-wire blade whose tip's phase swings by +-x
    (x = beta, 4 pi L / lambda; scatterers uniform from the hub to the tip): the mean
    over the blade of J_k(x r / L), (1 / x) int_0^x J_k(t) dt = (2 / x) sum_j
    J_(k + 2 j + 1)(x)."""
    from scipy.special import jv

    x = np.atleast_1d(np.asarray(x, float))
    j = np.arange(0, 2 * int(np.ceil(x.max())) + 40)
    return 2 / x * jv(int(k) + 2 * j[None, :] + 1, x[:, None]).sum(axis=1)


def first_pair_db(cpis: list, speeds: np.ndarray, n_blades: int, bin_hz: float) -> np.ndarray:
    """Per CPI the first blade-passing pair's level over the floor [dB]: on each side of
    the centre the strongest bin within 1 of any rotor's line B f_m, the weaker side
    (NaN where the CPI has no estimate)."""
    out = np.full(len(cpis), np.nan)
    for i, c in enumerate(cpis):
        sp = speeds[i][np.isfinite(speeds[i])]
        if not len(sp):
            continue
        n = len(c.z)
        off = np.round(n_blades * sp / bin_hz).astype(int)
        ctr = int(round(c.centre))
        near = np.arange(-1, 2)
        up = c.z[(ctr + off[:, None] + near[None, :]) % n].max()
        dn = c.z[(ctr - off[:, None] + near[None, :]) % n].max()
        out[i] = float(min(up, dn))
    return out


def one_order_visible(flight, n_blades: int) -> bool:
    """Whether the blades' physics lets one harmonic order of the blade-passing comb
    show, so that a lone sideband pair is the comb: the blade flash's Doppler extent
    kappa_max beta f (beta = 4 pi L / lambda, the tips' Doppler over the rotation
    rate f; kappa_max the upper end of :class:`.order.OrderConfig`'s ``extent_range``)
    ends short of the second harmonic 2 B f. Short blades at a long wavelength (a small
    drone in L band: beta ~3, two or three blades); False without ``blade_length_m``.
    Which order the pair is stays the order check's (:func:`.order.resolve_order`)."""
    from .order import OrderConfig

    L = flight.attrs.get("blade_length_m")
    if L is None or not np.isfinite(float(L)) or float(L) <= 0:
        return False
    beta = 4 * np.pi * float(L) / float(flight.wavelength_m)
    return bool(OrderConfig().extent_range[1] * beta < 2 * int(n_blades))


def cpi_means_of_spline(
    t_s: np.ndarray, nodes: np.ndarray, cpi_t: np.ndarray, n_fft: int, prf_hz: float, n_points: int = 64
) -> np.ndarray:
    """Window^2-weighted mean (Blackman-Harris, ``n_fft`` pulses at ``prf_hz``) over each
    CPI centred on ``cpi_t`` of the curve through (``t_s``, ``nodes``) [n, k] that every
    sampling variant reads from a log (:func:`microdoppler.rotors.sampling.log_curve`):
    float [len(cpi_t), k]."""
    w = window(n_fft) ** 2
    k = np.linspace(0, n_fft - 1, n_points).astype(int)
    wk = w[k] / w[k].sum()
    tt = cpi_t[:, None] + (k[None, :] - n_fft / 2) / prf_hz
    return np.einsum("ikm,k->im", log_curve(t_s, nodes)(tt), wk)


def instants_from_cpi_means(
    t_s: np.ndarray, means: np.ndarray, n_fft: int, prf_hz: float, *, iterations: int = 12, rtol: float = 1e-7
) -> np.ndarray:
    """Speeds at the CPI centres ``t_s`` whose natural cubic spline has the CPI means
    ``means`` [n, k] (:func:`cpi_means_of_spline`): the fixed point of
    x <- x + (means - A x), A the CPI-mean operator (close to the identity: its
    off-diagonal weights are ~0.08, so the iteration contracts). Fewer than 3 rows,
    or no convergence, leave the means as they are."""
    m = np.asarray(means, float)
    if len(t_s) < 3:
        return m.copy()
    x = m.copy()
    for _ in range(iterations):
        r = m - cpi_means_of_spline(t_s, x, t_s, n_fft, prf_hz)
        x = x + r
        if np.max(np.abs(r)) <= rtol * np.max(np.abs(m)):
            return x
    return (
        x
        if np.max(np.abs(m - cpi_means_of_spline(t_s, x, t_s, n_fft, prf_hz))) <= 1e-5 * np.max(np.abs(m))
        else m.copy()
    )


def _refine(
    flight: Flight,
    cfg: RotorSpeedConfig,
    speeds,
    sds,
    common,
    common_sd,
    body,
    t,
    hop,
    n_fft,
    B,
    M,
    n_pairs,
    progress=None,
    balance=None,
) -> int:
    """Step 9: each CPI with an estimate refitted on its I/Q (in place, with each fit's
    power balance into ``balance``; ``n_pairs`` [n_cpi]: the visible sideband pairs,
    which set the one-pair uncertainty); returns the number of CPIs refined. A CPI whose
    fit leaves its lines' range keeps the periodogram's estimate."""
    n = 0
    valid = np.flatnonzero(np.isfinite(common))
    if len(valid) == 0:
        return 0
    prf = float(flight.prf_hz)
    # the group's and the body's rates of change from the neighbouring CPIs
    rate = np.gradient(np.interp(t, t[valid], common[valid]), t) if len(valid) > 1 else np.zeros(len(t))
    body_rate = np.gradient(body, t) if len(t) > 1 else np.zeros(len(t))
    for k, i in enumerate(valid):
        if progress is not None and k % 64 == 0 and k > 0:
            progress(k, len(valid))
        x = np.asarray(flight.iq[i * hop : i * hop + n_fft])
        sp = speeds[i][np.isfinite(speeds[i])]
        lines = np.unique(np.round(sp, 9))
        res = refine_cpi(
            x,
            prf,
            B,
            M,
            body_hz=float(body[i]),
            body_rate_hz_s=float(body_rate[i]),
            lines_rev_s=lines,
            rate_rev_s2=float(rate[i]),
            n_pairs=int(n_pairs[i]),
            config=cfg.fit,
        )
        if res is None:
            continue
        speeds[i], sds[i] = res.speeds_rev_s, res.speeds_std_rev_s
        common[i], common_sd[i] = float(res.speeds_rev_s.mean()), res.mean_std_rev_s
        if balance is not None:
            balance[i] = res.balance
        n += 1
    if progress is not None:
        progress(len(valid), len(valid))
    return n


def _line_evidence(z: np.ndarray, cfg: RotorSpeedConfig) -> tuple[np.ndarray, np.ndarray]:
    """Spectral lines only: the height [dB] of every peak with ``line_prominence_db``
    over ``pair_snr_db``, spread over +-1 and +-2 bins (-100 elsewhere, NaN near
    masked bins)."""
    n = len(z)
    pk, _ = find_peaks(z, height=cfg.pair_snr_db, prominence=cfg.line_prominence_db)
    zpk = np.full(n, -100.0)
    zpk[pk] = z[pk]
    zpk1 = maximum_filter1d(zpk, 3)
    zpk2 = maximum_filter1d(zpk, 5)
    bad = maximum_filter1d((z <= -99.0).astype(np.uint8), 3).astype(bool)
    zpk1[bad] = np.nan
    zpk2[bad] = np.nan
    return zpk1, zpk2


def _centre(z: np.ndarray, zpk1: np.ndarray, f0: float, f_hz: np.ndarray, B: int, cfg: RotorSpeedConfig) -> float:
    """Centre of symmetry of the sidebands [fractional bin] near the track's Doppler
    ``f0`` (module doc, step 2)."""
    n = len(z)
    bin_hz = float(f_hz[1] - f_hz[0])
    g = np.clip(np.nan_to_num(zpk1, nan=-100.0) - cfg.pair_snr_db, 0, 30)
    i_track = (f0 - f_hz[0]) / bin_hz
    s_half = cfg.body_search_hz / bin_hz
    kmin = 0.7 * B * cfg.min_rev_s / bin_hz
    j = np.arange(int(np.floor(2 * (i_track - s_half))), int(np.ceil(2 * (i_track + s_half))) + 1)
    j = j[(j > 0) & (j < 2 * n - 2)]
    if len(j) and g.any():
        ii = np.flatnonzero(g)
        partner = j[:, None] - ii[None, :]
        use = (partner >= 0) & (partner < n) & (np.abs(2 * ii[None, :] - j[:, None]) >= 2 * kmin)
        m = np.where(use, g[ii][None, :] * g[np.clip(partner, 0, n - 1)], 0.0).sum(axis=1)
        if m.max() > 0:
            q = int(np.argmax(m))
            d = _parabolic(m[q - 1], m[q], m[q + 1]) if 0 < q < len(m) - 1 else 0.0
            return 0.5 * (j[q] + d)
    # no sidebands: the body peak near the track
    lo = max(1, int(np.floor(i_track - s_half)))
    hi = min(n - 2, int(np.ceil(i_track + s_half)))
    if hi > lo:
        q = lo + int(np.argmax(z[lo : hi + 1]))
        return q + _parabolic(z[q - 1], z[q], z[q + 1])
    return float(np.clip(i_track, 0, n - 1))


def _evidence(zpk1, zpk2, centre: float, f: np.ndarray, B: int, bin_hz: float, cfg: RotorSpeedConfig):
    """Pair evidence at speeds ``f`` (module doc, steps 3-4): E [N, len(f)] (dB over
    ``pair_snr_db`` of the weaker line of the pair n B f, 0 where none), ``examined``
    [N, len(f)] (both positions inside the band and unmasked) and R [len(f)]."""
    n = len(zpk1)
    N = cfg.n_harmonics
    T = cfg.pair_snr_db
    E = np.zeros((N, len(f)))
    examined = np.zeros((N, len(f)), bool)
    first = np.zeros(len(f), bool)
    lim = 0.49 * n  # stay inside +-prf/2 (no aliased lines)
    for k in range(N):
        d = (k + 1) * B * f / bin_hz
        up, dn = centre + d, centre - d
        inband = (np.abs(up - n / 2) < lim) & (np.abs(dn - n / 2) < lim)
        q = np.minimum(_at(zpk1, up), _at(zpk1, dn))
        ok = np.isfinite(q) & inband
        examined[k] = ok
        E[k] = np.where(ok, np.clip(np.nan_to_num(q, nan=-100.0) - T, 0.0, 40.0), 0.0)
        if k == 0:
            q2 = np.minimum(_at(zpk2, up), _at(zpk2, dn))
            first = ok & (np.nan_to_num(q2, nan=-100.0) >= T)
    # the lowest pair must be visible (else a sub-harmonic or a ghost); where n = 1 is
    # masked (clutter), the n = 2 and n = 3 pairs stand in (n = 2 alone would accept
    # half the true speed, whose even harmonics are the true ones)
    if N > 2:
        first |= ~examined[0] & (E[1] > 0) & (E[2] > 0)
    R = np.where(first, E.sum(axis=0), 0.0)
    return E, examined, R


def _viterbi(emis: np.ndarray, kmax: int, penalty: float) -> np.ndarray:
    """Best path (state index per CPI) maximising emission minus ``penalty`` per state
    step, steps of at most ``kmax`` states."""
    n_t, n_s = emis.shape
    V = emis[0].copy()
    back = np.zeros((n_t, n_s), np.int32)
    idx = np.arange(n_s)
    for i in range(1, n_t):
        best = np.full(n_s, -np.inf)
        arg = np.zeros(n_s, np.int32)
        for k in range(-kmax, kmax + 1):
            src = idx - k
            ok = (src >= 0) & (src < n_s)
            cand = np.full(n_s, -np.inf)
            cand[ok] = V[src[ok]] - penalty * abs(k)
            better = cand > best
            best[better] = cand[better]
            arg[better] = src[better]
        V = best + emis[i]
        back[i] = arg
    path = np.zeros(n_t, int)
    path[-1] = int(np.argmax(V))
    for i in range(n_t - 1, 0, -1):
        path[i - 1] = back[i, path[i]]
    return path


def _side_bins(centre: float, d0: float, d1: float, sign: int, n: int) -> np.ndarray:
    """Bins whose offset from ``centre`` (times ``sign``) lies in [d0, d1]."""
    if sign > 0:
        a, b = int(np.ceil(centre + d0)), int(np.floor(centre + d1))
    else:
        a, b = int(np.ceil(centre - d1)), int(np.floor(centre - d0))
    return np.arange(max(a, 0), min(b, n - 1) + 1)


def _walk(z: np.ndarray, start: int, direction: int, stop_db: float, limit: int) -> int:
    """Last bin from ``start`` in ``direction`` while z stays above ``stop_db``."""
    j = start
    while 0 < j + direction < len(z) - 1 and abs(j + direction - start) <= limit and z[j + direction] > stop_db:
        j += direction
    return j


def _centroid(z: np.ndarray, bins: np.ndarray, centre: float, sign: int):
    """Power-weighted mean offset [bins] (noise mean subtracted), its noise std and
    the line power, over ``bins`` on one side; None without power or on a masked bin."""
    if len(bins) == 0:
        return None
    zz = z[bins].astype(np.float64)
    if np.any(zz <= -99.0):
        return None
    w = 10 ** (zz / 10) - 1.0
    tot = w.sum()
    if tot <= 0:
        return None
    off = sign * (bins - centre)
    mu = float(np.sum(w * off) / tot)
    var = float(np.sum((off - mu) ** 2 * (2 * np.maximum(w, 0) + 1)) / tot**2)
    return mu, var, float(tot)


def _pair_db(c: _Cpi, n: int, f: np.ndarray, B: int, bin_hz: float) -> np.ndarray:
    """Pair spectrum of harmonic ``n`` at speeds ``f``: the weaker of the two lines at
    centre +- n B f [dB over the floor] (linear interpolation; masked bins -100)."""
    d = n * B * f / bin_hz
    up = np.interp(c.centre + d, np.arange(len(c.z)), c.z, left=-100.0, right=-100.0)
    dn = np.interp(c.centre - d, np.arange(len(c.z)), c.z, left=-100.0, right=-100.0)
    return np.minimum(up, dn)


def _peaks(q: np.ndarray, height: float, prominence: float) -> np.ndarray:
    pk, _ = find_peaks(np.r_[-100.0, q, -100.0], height=height, prominence=prominence)
    return pk - 1


def _rotors(c: _Cpi, f_path: float, fgrid, cfg: RotorSpeedConfig, B, M, bin_hz):
    """The rotor lines near the tracked speed ``f_path`` (module doc, steps 5-6): a
    :class:`_Lines`, or None without a visible pair there."""
    T = cfg.pair_snr_db
    N = cfg.n_harmonics
    lo = np.searchsorted(fgrid, f_path / cfg.group_ratio)
    hi = np.searchsorted(fgrid, f_path * cfg.group_ratio)
    fw = fgrid[lo:hi]
    if len(fw) < 3:
        return None
    z = c.z.astype(np.float64)
    zpk1, zpk2 = _line_evidence(z, cfg)
    E, examined, Rw = _evidence(zpk1, zpk2, c.centre, fw, B, bin_hz, cfg)
    if Rw.max() <= 0:
        return None
    pos = Rw > 0
    n1 = next((k + 1 for k in range(min(N, 3)) if examined[k][pos].all()), None)
    if n1 is None:
        return None
    q1 = _pair_db(c, n1, fw, B, bin_hz)
    pk = _peaks(q1, T, cfg.line_prominence_db)
    if len(pk) == 0:
        return None
    # a line at ~twice a strong lower line's speed is that line's second harmonic
    strong = fw[pk][q1[pk] >= q1[pk].max() - 10.0].min()
    pk = pk[fw[pk] < 1.8 * strong]
    # at most M clusters: the strongest
    pk = np.sort(pk[np.argsort(q1[pk])[::-1][:M]])
    for _ in range(M + 1):
        anchors = fw[pk]
        cut = [pk[a] + int(np.argmin(q1[pk[a] : pk[a + 1] + 1])) for a in range(len(pk) - 1)]
        edges = [float(fw[j]) for j in cut]
        # each cluster's extent: where its first pair stays visible, within its edges
        ext = []
        for ci, j in enumerate(pk):
            a0 = cut[ci - 1] if ci > 0 else 0
            a1 = cut[ci] if ci < len(cut) else len(fw) - 1
            below = np.flatnonzero(q1[a0 : j + 1] < T)
            above = np.flatnonzero(q1[j : a1 + 1] < T)
            ext.append((fw[a0 + below[-1]] if len(below) else fw[a0], fw[j + above[0]] if len(above) else fw[a1]))
        f_lo = min(ext[0][0], anchors[0] * (1 - 0.5 * cfg.smear_rel))
        f_hi = max(ext[-1][1], anchors[-1] * (1 + 0.5 * cfg.smear_rel))
        per_n = []
        for nn in range(n1, min(N, n1 + cfg.n_measure - 1) + 1):
            if nn * f_hi >= (nn + 1) * f_lo:
                break
            if not examined[nn - 1, pk].all():
                break
            # a pair of this harmonic visible anywhere in the group (a line between two
            # higher-harmonic lines has none at its own peak, which is where the rotor
            # counts are least clear and every harmonic's power share helps)
            if not (E[nn - 1, (fw >= f_lo) & (fw <= f_hi)] > 0).any():
                continue
            st = _cluster_stats(
                z, c.centre, nn, B, bin_hz, anchors, edges, f_lo, f_hi, cfg, starts=(ext[0][0], ext[-1][1])
            )
            if st is not None:
                per_n.append(st)
        if not per_n:
            return None
        frac = np.mean([s[2] / s[2].sum() for s in per_n], axis=0)
        weak = frac < cfg.min_share
        if not weak.any() or len(pk) == 1:
            break
        pk = np.delete(pk, int(np.argmin(frac)))  # a smear shoulder or a ghost: merge it away
    sp_n = np.array([s[0] for s in per_n])  # [n_harm, n_clusters]
    var_n = np.array([s[1] for s in per_n]) + (cfg.rel_floor * sp_n) ** 2
    w = 1.0 / var_n
    cl_speed = (w * sp_n).sum(0) / w.sum(0)
    cl_var = 1.0 / w.sum(0)
    if len(per_n) > 1:  # scatter over harmonics beyond the noise: inflate (Birge ratio)
        chi2 = (w * (sp_n - cl_speed) ** 2).sum(0) / (len(per_n) - 1)
        cl_var = cl_var * np.maximum(chi2, 1.0)
    # split clusters into the lines that >= 2 higher harmonics resolve
    bounds = [fw[0]] + edges + [fw[-1]]
    members, exact = [], []
    for ci in range(len(pk)):
        sel = (fw >= max(bounds[ci], min(ext[ci][0], anchors[ci] * (1 - 0.5 * cfg.smear_rel)))) & (
            fw <= min(bounds[ci + 1], max(ext[ci][1], anchors[ci] * (1 + 0.5 * cfg.smear_rel)))
        )
        found = []
        for nn in range(n1 + 1, N + 1):
            if not examined[nn - 1, sel].all() or not (E[nn - 1, sel] > 0).any():
                continue
            qn = _pair_db(c, nn, fw[sel], B, bin_hz)
            p = _peaks(qn, T, cfg.line_prominence_db)
            if len(p):
                found.append((len(p), nn, fw[sel][p]))
        counts = sorted((f[0] for f in found), reverse=True)
        k = counts[1] if len(counts) > 1 else 1
        at_k = [(f[1], f[2]) for f in found if f[0] == k]
        if 1 < k <= M and at_k:
            nn, f_lines = max(at_k, key=lambda x: x[0])
            f_lines = np.sort(np.asarray(f_lines, float))
            # each line's own centroid at the harmonic that resolves them (free of the
            # interference that biases the cluster's centroid at n1)
            fs = fw[sel]
            qn = _pair_db(c, nn, fs, B, bin_hz)
            ip = np.searchsorted(fs, f_lines)
            valleys = [float(fs[ip[a] + int(np.argmin(qn[ip[a] : ip[a + 1] + 1]))]) for a in range(len(ip) - 1)]
            st = _cluster_stats(
                z, c.centre, nn, B, bin_hz, f_lines, valleys, f_lo, f_hi, cfg, outer=(float(fs[0]), float(fs[-1]))
            )
            if st is not None:
                members.append(st[0])
                exact.append(True)
            else:
                members.append(f_lines)
                exact.append(False)
        else:
            members.append(np.array([cl_speed[ci]]))
            exact.append(True)
    # a harmonic's pair is visible near one of the lines (not a neighbouring harmonic's)
    near = np.zeros(len(fw), bool)
    for f_line in np.concatenate(members):
        near |= np.abs(fw - f_line) <= 0.02 * f_line
    visible = (E[:, near] > 0).any(axis=1)
    if not visible.any():  # no pair at the lines themselves: no estimate, never a guess
        return None
    # rotors sharing a cluster: placed to about a bin at the highest visible harmonic
    n_top = int(np.flatnonzero(visible).max()) + 1 if visible.any() else n1
    within = (bin_hz / (n_top * B)) ** 2
    return _Lines(cl_speed, cl_var, frac, members, exact, within, int(visible.sum()), int(sum(len(m) for m in members)))


@dataclass
class _Lines:
    """The rotor lines of one CPI, per cluster (lines not resolved at the lowest
    harmonic): centroid speed [rev/s], its variance, share of the group's power, the
    speeds of the lines inside it (``exact``: measured by their own centroids, else
    spaced from the speed grid) and the variance of placing a line inside a cluster."""

    speed: np.ndarray
    var: np.ndarray
    frac: np.ndarray
    members: list
    exact: list
    within_var: float
    n_pairs: int
    n_lines: int

    def allocations(self, M: int) -> list[np.ndarray]:
        """Every rotor count per cluster (>= 1 each) summing to M."""
        K = len(self.members)
        if K >= M:
            return [np.ones(K, int)]
        extra = M - K
        out = []
        for cut in itertools.combinations(range(extra + K - 1), K - 1):
            edges = (-1,) + cut + (extra + K - 1,)
            out.append(1 + np.diff(edges) - 1)
        return out

    def missing(self, count: np.ndarray) -> int:
        """Lines seen but not given a rotor of their own under ``count``."""
        return int(sum(max(0, len(m) - c) for m, c in zip(self.members, count)))

    def mean_var(self, count: np.ndarray) -> float:
        """Variance of the mean rotor speed for the counts ``count`` (the placement of
        rotors inside a cluster does not move their mean)."""
        return float(np.sum((np.asarray(count) / np.sum(count)) ** 2 * self.var))

    def rotors(self, count: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sorted rotor speeds [M] and their std for the counts ``count``: the lines of
        a cluster keep their spacing (from the speed spectrum) around its centroid
        (the closest lines merged while there are more lines than rotors); rotors
        beyond the lines sit at the centroid."""
        sp, var = [], []
        for ci, mem in enumerate(self.members):
            mem = list(np.sort(mem))
            while len(mem) > max(int(count[ci]), 1):
                j = int(np.argmin(np.diff(mem)))
                mem[j : j + 2] = [0.5 * (mem[j] + mem[j + 1])]
            mem = np.array(mem)
            if not self.exact[ci]:  # line spacing from the speed grid, centred on the centroid
                mem = mem - mem.mean() + self.speed[ci]
            lines = list(mem) + [self.speed[ci]] * int(count[ci] - len(mem))
            shared = len(mem) > 1 or count[ci] > len(mem)
            v = self.var[ci] + (self.within_var if shared else 0.0)
            sp += lines
            var += [v] * len(lines)
        sp, sd = np.array(sp), np.sqrt(np.array(var))
        o = np.argsort(sp, kind="stable")
        return sp[o], sd[o]


def _pattern(speeds: np.ndarray) -> np.ndarray:
    return speeds / speeds.mean() - 1


def _share_cost(frac: np.ndarray, count: np.ndarray, M: int, cfg: RotorSpeedConfig) -> float:
    """-2 log-likelihood of the power shares ``frac`` [n_clusters] for the rotor counts
    ``count``: a line of k rotors has share k / M with variance ``spread_share_sd``^2 +
    ``spread_interference_sd``^2 k (k - 1) / 2 (each pair of rotors on it interferes)."""
    k = np.asarray(count, float)
    var = cfg.spread_share_sd**2 + cfg.spread_interference_sd**2 * k * (k - 1) / 2
    return float(np.sum((frac - k / M) ** 2 / var + np.log(var)))


def _allocate(lines: list, M: int, cfg: RotorSpeedConfig) -> list:
    """(rotor counts per cluster, mean speed, its variance from the counts) for every
    CPI (None where no lines).

    Close rotors merge into one line and interfere, so a line's power tells its
    rotor count poorly. The pattern of the rotors' relative speeds changes slowly:
    where a CPI has fewer lines than rotors, its counts are chosen to match both the
    power shares and the median pattern of the CPIs within +-``pattern_cpis`` whose
    every rotor was seen as its own line.
    """
    n = len(lines)
    opts = [None if L is None else L.allocations(M) for L in lines]
    full = [L is not None and L.n_lines == M and len(L.members) <= M for L in lines]
    pats = [None if L is None else [_pattern(L.rotors(cnt)[0]) for cnt in opts[i]] for i, L in enumerate(lines)]
    # the relative-speed pattern of the CPIs where every rotor has its own line
    pattern = [
        _pattern(L.rotors(np.array([len(m) for m in L.members]))[0]) if full[i] else None for i, L in enumerate(lines)
    ]
    W = cfg.pattern_cpis
    out = []
    for i, L in enumerate(lines):
        if L is None:
            out.append(None)
            continue
        cost = np.array(
            [
                float(np.sum((L.frac - cnt / M) ** 2)) / cfg.power_share_sd**2 + cfg.split_cost * L.missing(cnt)
                for cnt in opts[i]
            ]
        )
        refs = [pattern[j] for j in range(max(0, i - W), min(n, i + W + 1)) if j != i and full[j]]
        if refs and len(opts[i]) > 1:
            ref = np.median(np.array(refs), axis=0)
            cost = cost + np.array([float(np.sum((p - ref) ** 2)) for p in pats[i]]) / cfg.pattern_sd**2
        # MAP counts for the rotors; the mean speed averages over the counts' posterior
        # (weights exp(-cost / 2)), its spread adds to the uncertainty
        w = np.exp(-0.5 * (cost - cost.min()))
        w /= w.sum()
        means = np.array([L.rotors(cnt)[0].mean() for cnt in opts[i]])
        mu = float(np.sum(w * means))
        # the uncertainty: the posterior under the measured (count-dependent) share scatter
        cv = np.array([_share_cost(L.frac, cnt, M, cfg) + cfg.split_cost * L.missing(cnt) for cnt in opts[i]])
        if refs and len(opts[i]) > 1:
            cv = cv + np.array([float(np.sum((p - ref) ** 2)) for p in pats[i]]) / cfg.pattern_sd**2
        wv = np.exp(-0.5 * (cv - cv.min()))
        wv /= wv.sum()
        out.append((opts[i][int(np.argmin(cost))], mu, float(np.sum(wv * (means - mu) ** 2))))
    return out


def _cluster_stats(z, centre, nn, B, bin_hz, anchors, edges, f_lo, f_hi, cfg, outer=None, starts=None):
    """Per cluster at harmonic ``nn``: (speed [rev/s], noise variance [(rev/s)^2],
    power), arrays [n_clusters]; None when a region touches a masked bin. Inner
    bounds are the ``edges`` [rev/s]; the outer ones walk out of the outermost lines
    while above ``noise_db`` (at most ``smear_rel``, and halfway to the neighbouring
    harmonic groups or the body; ``outer`` [rev/s] bounds them too). The walks start
    at ``starts`` [rev/s] (default the outermost anchors)."""
    n = len(z)
    k_hz = nn * B / bin_hz  # bins per rev/s at this harmonic
    d0, d1 = (anchors[0] * k_hz, anchors[-1] * k_hz) if starts is None else (starts[0] * k_hz, starts[1] * k_hz)
    lim_lo = 0.5 * ((nn - 1) * f_hi + nn * f_lo) * k_hz / nn if nn > 1 else 0.5 * f_lo * k_hz
    lim_hi = 0.5 * (nn * f_hi + (nn + 1) * f_lo) * k_hz / nn
    if outer is not None:
        lim_lo, lim_hi = max(lim_lo, outer[0] * k_hz), min(lim_hi, outer[1] * k_hz)
    scale = bin_hz / (2 * nn * B)
    K = len(anchors)
    sp, var, pw = [], [], []
    for ci in range(K):
        res = []
        for sign in (1, -1):
            if ci > 0:
                a0 = edges[ci - 1] * k_hz
            else:
                j0 = int(np.round(centre + sign * d0))
                stop = max(cfg.noise_db, float(np.max(z[max(j0 - 2, 0) : j0 + 3])) - cfg.line_range_db)
                j = _walk(z, j0, -sign, stop, int(np.ceil(cfg.smear_rel * d0)) + 4)
                a0 = max(sign * (j - centre), lim_lo)
            if ci < K - 1:
                a1 = edges[ci] * k_hz
            else:
                j0 = int(np.round(centre + sign * d1))
                stop = max(cfg.noise_db, float(np.max(z[max(j0 - 2, 0) : j0 + 3])) - cfg.line_range_db)
                j = _walk(z, j0, sign, stop, int(np.ceil(cfg.smear_rel * d1)) + 4)
                a1 = min(sign * (j - centre), lim_hi)
            r = _centroid(z, _side_bins(centre, a0, a1, sign, n), centre, sign)
            if r is None:
                return None
            res.append(r)
        sp.append((res[0][0] + res[1][0]) * scale)
        var.append((res[0][1] + res[1][1]) * scale**2)
        pw.append(min(res[0][2], res[1][2]))
    return np.array(sp), np.array(var), np.array(pw)
