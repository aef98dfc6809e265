"""Which comb the HERM lines are: the rotation rate's harmonic order, with its doubt.

:func:`microdoppler.rotors.speed.estimate_rotor_speeds` measures the spacing of a
flight's HERM lines well, and reads it as the blade-passing rate B f of rotors turning
at f [rev/s]. Other line sets share that spacing, and with them the speed is off by a
simple ratio while the lines are measured well:

- unequal blades (a tag, a chip, a different pitch): a rotor returns lines at every
  multiple of f, not only at multiples of B f; read as a blade-passing comb they give
  f / B (0.5x for two blades);
- Doppler beyond +-PRF/2 folds: the lines wrap modulo the PRF and interleave with the
  unfolded ones, so that a comb of a different spacing (1.5x, 2x) matches them;
- sub- and super-harmonics: a comb at f / 2 contains every line of the true one, one
  at 2 f half of them.

:func:`resolve_order` (called by ``estimate_rotor_speeds`` unless ``order=False``)
scores candidate rotation rates by the likelihood of the CPIs' spectral lines under a
line model that knows both line families and folding, and by physics, and where two
rates remain plausible says so.

1. The lines: the order is judged on the periodogram's lines (steps 1-8 of
   :mod:`~microdoppler.rotors.speed`; an I/Q fit made at a wrong order is biased).
   Their comb's rate is the median rotor's, the rotors' spread per CPI that of the
   lines within 15 % of it, widened by the spread of the peaks around the comb's
   first three blade-passing harmonics and by ``spread_margin``.
2. Candidates: the comb's rate times 1/3, 1/2, 2/3, 1, 3/2, 2, 3 (and 1/B, B), plus
   the ``screen_keep`` best local maxima of a coarse likelihood (``screen_cpis`` CPIs)
   over ``min_rev_s``-``max_rev_s`` in steps of ``screen_step``, away from the
   ratios (``snap_rel``), each with the lines' time profile and rotor spread.
3. Physics excludes a candidate whose blade tips would pass ``max_tip_mach`` (2 pi f L
   over the speed of sound) or whose blade-tip Doppler the lines pass: the blade
   energy's extent (per CPI the M-th farthest line of ``line_db`` + 3 dB, the median
   over CPIs; folded lines make it a lower bound) must not exceed (kappa_max beta +
   ``tail_harmonics`` beta^(1/3)) f, where beta f = 2 (2 pi f L) / lambda = f_max is
   the tips' Doppler, the blade flash's Doppler extent (beta = 4 pi L / lambda; the
   tip's Bessel lines J_k(beta) fall off over ~beta^(1/3) harmonics beyond k = beta);
   with ``tail_level`` the tail reaches only as far as a line can stand ``line_db`` + 3
   dB over the floor: where the fall-off Ai(m) / Ai(0) (step 4) comes to the strongest
   line's height over the floor (per CPI, the median over CPIs) less ``line_db`` + 3 dB,
   plus ``line_sd_db`` (a line's scatter), in units of (beta / 2)^(1/3) harmonics.
4. Line model, per CPI, for a rate f (rotors at f p_m): rotation harmonic k has a line
   at body + s k f (s = +-1, folded modulo the PRF into the spectrum) within a window
   covering the rotors' spread k f (p_min..p_max) plus 1.5 bins; the blade-passing
   family (k a multiple of B) has the level a - beta_d d (d = k f p_max), the
   rotation-rate family (other k) that level times rho^2 (rho = 0 for equal blades;
   fitted, at most :func:`rho_max` of one blade ``max_weak_blade_db`` weaker than the
   others; a CPI whose explained peaks are all rotation-rate lines takes its level from
   them, ``rotation_level``), and no line lies beyond kappa f_max + the tail (a window in the tail that
   holds no peak expects the tip's fall-off, ``tail_fall``); kappa in ``extent_range``
   (the stated tolerance: below 1 for a rotor plane seen at an elevation, a weak tip, a
   drooping envelope; above 1 for a blade length known to ~10 %). The level a per CPI
   and the decay beta_d [dB/Hz] are fitted by least squares to the explained peaks.
   Observations are the spectrum's peaks (``line_db`` over the local floor,
   ``prominence_db``; clutter and body bands masked) within the analysed band: offsets
   from the body where the comb's rotation harmonics stay apart (half over the
   relative spread; beyond, the rotors' lines merge into a continuum that tells no
   order). A peak inside a window of a line has the density (1 - fade) N(y; mu,
   ``line_sd_db``) / width; a window without a peak 1 - (1 - fade) Phi((mu -
   ``line_db``) / ``line_sd_db``); a peak no line explains is spurious,
   ``spurious_per_cpi`` per CPI spread over the analysed band (+-its edge: no peak
   beyond it is observed) and over ``spurious_range_db``.
   The data are the same for every candidate (every peak is explained or spurious), so
   their likelihoods compare: a sub-harmonic pays for its empty windows, a
   super-harmonic or a wrong folding for the peaks it leaves unexplained, the
   rotation-rate family at twice the rate for lines as strong as the blade-passing
   ones (rho capped), a rate too low for lines beyond its tips' Doppler.
5. Weighing: the log-likelihood over ``temperature`` (CPIs overlap by half), plus
   ``prior_lines`` for the comb the lines were read as. An alternative's evidence is
   scaled down by the CPIs' own scatter (the per-CPI differences d_i have variance
   ~2 mean(d) where the model holds; a larger variance scales the evidence by 2 mean /
   variance) and where the two combs' windows cover more than ``coverage_free`` of the
   band (folded, dense lines: a peak is explained by chance) by (1 - coverage) / (1 -
   ``coverage_free``), at least ``min_evidence``; relative likelihood exp(-evidence).
   The order is the candidate whose relative likelihood times the blade-tip speed's
   prior (2 pi f L, log-normal about ``tip_speed_mps``; with ``blade_length_m``) is
   largest: a drone's tips turn at a typical speed, and where two orders explain the
   lines alike (the likelihoods within a factor of a few) the one at a typical tip speed
   is the more probable. Where that is not the likeliest candidate, the likeliest is
   listed at relative likelihood 1 (ambiguous) and ``info["order"]["tip_prior"]`` says so.
6. The speeds: where the chosen rate is the comb's, the estimate stands; else it is
   measured again with the search confined to the chosen rate's range (``rerun``,
   widened by ``rerun_margin``) and, where that does not find it within 3 %, the
   lines' estimate is scaled. Whatever the order, a rotor more than
   ``rotor_spread_max`` from the median rotor (of the CPI and its neighbours) sat on a
   line of another order or family; it goes to the median, the change into its sigma
   (``info["order"]["n_rotors_to_median"]``). Where the speeds' median over CPIs then
   departs from the chosen rate by more than ``depart_max``, the rotors split between
   two rates' lines: the speeds are scaled to the chosen rate, the order is ambiguous,
   and the speeds as measured are listed (``departs``, ``split``). Where the lines
   found no comb at all over the whole range (they may follow a sub-harmonic path into
   nothing), the screen's likeliest rates are each searched again within
   ``rescue_rel`` (:func:`_rescue`).

Where another candidate's relative likelihood, or its posterior odds against the chosen
one (the relative likelihood times the ratio of their tip speeds' priors), is
``ambiguous_at`` or more, the flight's order is ambiguous: ``RotorEstimate.info["order"]``
lists the alternatives (down to ``report_at``, and those plausible by their posterior
odds; ``posterior_odds`` beside their relative likelihoods), the store's
``motors_radar`` attributes ``rotor_order_alternatives_rev_s`` and
``rotor_order_relative_likelihood`` carry them (:func:`order_attrs`), ``import`` prints
:func:`ambiguity_line`, and every CPI's uncertainty includes the order's: sigma^2 +
sum_h w_h (v_h - v)^2 over the plausible candidates h (weights w their relative
likelihoods normalised over them, speeds v_h = v f_h / f), the spread of the mixture
about the reported speed (a candidate below ``ambiguous_at`` lies outside the mixture's
95 % interval and is listed without widening sigma).

Tested on recordings the project did not shape (:mod:`microdoppler.examples`,
``tests/test_rotor_order.py``; ``benchmarks/eval_any_radar.py``); the settings were
chosen on the generator's seeds 1-99 and on the emulated flights, the benchmark runs on
seeds from 1000.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace

import numpy as np
from scipy.signal import find_peaks
from scipy.special import airy, log_ndtr

from ..configfields import check_ranges, knob
from ..spectra.floor import local_floor_db
from ..spectra.periodogram import stft, window

METHOD = "order/7"
SOUND_MPS = 343.0
C_MPS = 299_792_458.0


@dataclass(frozen=True)
class OrderConfig:
    """Settings of :func:`resolve_order` (see the module docstring).

    The fields from ``max_cpis`` on are fixed settings (``config=False`` knobs, each
    described by its field): those from ``max_cpis`` to ``rescue_tries`` left the
    settings once, as ``order/7``'s values: perturbed x0.5 and x2 one at a time on the
    20 recordings of ``benchmarks/order_fingerprint.py``, none changed a recording's
    chosen order, ambiguity mark or mean speed
    (``benchmarks/records/ablate_order_config.json``). The last three are the fixed
    settings of :mod:`~microdoppler.rotors.plausibility`'s checks. ``info["order"]["settings"]``
    lists every field but :data:`NOT_STORED` (:func:`stored_settings`).

    Parameters
    ----------
    min_rev_s, max_rev_s : float
        Plausible rotation rates [rev/s] of the mean rotor.
    max_tip_mach : float
        Blade tips faster than this (Mach) exclude a candidate.
    extent_range : (float, float)
        Bounds of kappa, the blade flash's Doppler extent over 2 (2 pi f L) / lambda.
    max_weak_blade_db : float
        The rotation-rate family's level is at most that of one blade this much weaker
        than the others (amplitude, 20 log10).
    line_db, prominence_db : float
        A peak stands ``line_db`` over the local floor with ``prominence_db``.
    line_sd_db : float
        Spread of a line's level about the envelope [dB].
    fade : float
        Probability that a line falls out (fading, interference of rotors).
    spurious_per_cpi, spurious_range_db : float
        Peaks no rotor explains: expected count per CPI over the band, and the span of
        their heights above ``line_db``.
    clutter_guard_hz, body_guard_hz : float
        Masked bands around 0 Hz and the body [Hz].
    screen_step, screen_keep, min_separation : float, int, float
        Screen grid (relative step), local maxima kept, and their least separation.
    temperature : float
        The log-likelihood is divided by this before candidates are weighed.
    ambiguous_at : float
        Alternatives with this relative likelihood or more make the order ambiguous.
    spread_margin : float
        A line window covers the estimate's rotor spread widened by this (relative)
        on either side, for the rotors the lines did not separate.
    tail_harmonics : float
        Lines may reach this many times beta^(1/3) rotation harmonics beyond kappa
        f_max (beta = 4 pi L / lambda: the Bessel lines of the tip fall off over
        ~beta^(1/3) harmonics beyond k = beta).
    rescue_spread, rescue_rel : float
        Where the lines found no comb: the rotors' assumed spread for the screen, and the
        relative half-width of each confined search (of ``rescue_tries`` rates).
    coverage_free, min_evidence : float
        Where two combs' windows cover more than ``coverage_free`` of the spectrum
        (folded, dense lines), the evidence between them is scaled by
        (1 - coverage) / (1 - coverage_free), at least ``min_evidence``.
    prior_lines : float
        Log-likelihood advantage of the comb the lines were read as (the estimator's
        own evidence: its first pair visible, its harmonics).
    snap_rel : float
        A screen maximum within this (relative) of a simple ratio of the lines' comb is
        that ratio (the lines measure the spacing; a nearby maximum is no other order).
    rotor_spread_max : float
        The rotors of one drone turn within this (relative) of their median rotor over
        the CPI and its neighbours. A rotor beyond it sat on another order's or
        family's line (an unequal blade's rotation-rate line read as a blade-passing
        one, a scaled estimate's rotor on a third order's line: 1.25-2x): it is put at
        the median rotor and the change enters the uncertainty. The price: a true rotor
        beyond it in a hard manoeuvre is moved too. Must be > 0; a larger value keeps
        more misplaced rotors (the trade-off measured: ``docs/experiments.md``).
    depart_max : float
        The speeds reported (measured again, or the lines' estimate scaled, with rotors far
        from the others put at the median, step 6) keep the chosen rate's order only
        within this (log ratio of their median over CPIs to the rate). Beyond it the rotors
        split between the lines of two rates and the median took the other (rotors at
        0.8x and 1.2x the chosen rate): the speeds are scaled to the chosen rate (which
        the line model measured on every CPI; their median over CPIs becomes it), the order
        is ambiguous with the speeds as measured listed at relative likelihood 1, and the
        uncertainty includes both (their equal mixture). The value is ``snap_rel``'s:
        within it a rate is the same order (``order/6``; inf: ``order/5``).
    tail_level : bool
        The tail of step 3 reaches no farther than the tip's fall-off lets a line stand
        ``line_db`` + 3 dB over the floor below the strongest line (plus ``line_sd_db``):
        a weak recording's lines cannot pass the tips' Doppler by 2 beta^(1/3)
        harmonics, where the fall-off is ~30 dB (``order/5``; False: ``order/4``).
    tail_fall : bool
        A line window beyond kappa f_max that holds no peak costs what a line of the
        tip's fall-off would: its expected level is lowered by 20 log10(Ai(m) / Ai(0))
        (the Airy function; m the offset beyond kappa f_max in units of (beta / 2)^(1/3)
        rotation harmonics, the width over which J_k(beta) falls beyond k = beta), not
        the envelope's. Peaks there are scored at the envelope's level as before
        (kappa is known only to the stated tolerance). False: every window at the
        envelope's level (``order/1``).
    rotation_level : bool
        A CPI whose explained peaks are all of the rotation-rate family (its
        blade-passing lines beyond the analysed band, faded or masked) takes its level
        from them (the blade-passing lines 1 / rho stronger; rho fitted on the CPIs
        that show both families, else at its cap); the rho fit uses only CPIs with a
        blade-passing peak. False: such a CPI's level is the floor's, so that its
        rotation-rate lines read as spurious (``order/2``).
    tip_speed_mps, tip_speed_log_sd : float
        The prior of the blade-tip speed 2 pi f L [m/s] (the median rotor's; with
        ``blade_length_m``): log-normal about ``tip_speed_mps`` with this standard
        deviation of its logarithm. The order is the candidate with the largest relative
        likelihood (tempered, step 5) times this prior; where that is not the likeliest
        candidate, the likeliest is listed with relative likelihood 1 (the order is
        ambiguous). The centre is the project's drone catalogue
        (:data:`microdoppler.synthesis.radar.DRONE_MODELS`: Inspire 2 at 80 rev/s with
        0.19 m blades, 96 m/s; Matrice 300, 60 rev/s and 0.22 m, 83 m/s; Mini 2, 180
        rev/s and 0.06 m, 68 m/s; their geometric mean 81 m/s); 0.3 puts 95 % of the
        prior between 44 and 144 m/s (a large slow propeller to a small drone at full
        throttle, tip Mach 0.13-0.42); the hard limit stays ``max_tip_mach``. It decides
        only between candidates whose likelihoods are within a factor of ~15 (2x the
        rate moves the prior by exp(ln(2)^2 / (2 sd^2)) = 14 at most about the centre).
        0.4 is ``order/6`` (95 % between 36 and 176 m/s). A drone whose tips turn outside
        ~45-145 m/s is drawn towards the typical speed where the lines tie, and the
        likelier rate is then listed (the order ambiguous). Must be >= 0; 0: no prior
        (``order/3``). How 0.3 was chosen: ``docs/experiments.md``.
    """

    min_rev_s: float = 20.0
    max_rev_s: float = 400.0
    max_tip_mach: float = 0.7
    extent_range: tuple = (0.6, 1.1)
    max_weak_blade_db: float = 12.0
    line_db: float = 10.0
    prominence_db: float = 6.0
    line_sd_db: float = 5.0
    fade: float = 0.05
    spurious_per_cpi: float = 1.0
    spurious_range_db: float = 50.0
    clutter_guard_hz: float = 20.0
    body_guard_hz: float = 20.0
    screen_step: float = 0.004
    screen_keep: int = 6
    min_separation: float = 0.03
    temperature: float = 2.0
    ambiguous_at: float = 0.05
    spread_margin: float = 0.01
    tail_harmonics: float = 2.0
    rescue_spread: float = 0.05
    rescue_rel: float = 0.15
    coverage_free: float = 0.5
    min_evidence: float = 0.05
    prior_lines: float = 4.0
    snap_rel: float = 0.08
    rotor_spread_max: float = 0.25
    depart_max: float = 0.08
    tail_fall: bool = True
    tail_level: bool = True
    rotation_level: bool = True
    tip_speed_mps: float = 80.0
    tip_speed_log_sd: float = 0.3
    max_cpis: int = knob(
        64,
        "CPIs used (evenly spread, preferring non-overlapping ones) for the likelihood (a bound on the cost; the "
        "ablation's recordings have 4-34 CPIs, so x0.5 bound one only).",
        minimum=1,
        config=False,
    )
    screen_cpis: int = knob(
        24, "CPIs of the screen (step 2; evenly spread, preferring non-overlapping ones).", minimum=1, config=False
    )
    report_at: float = knob(
        0.01,
        "Alternatives below this relative likelihood (and below ``ambiguous_at`` in posterior odds) are not "
        "listed; they make no order ambiguous and widen no uncertainty.",
        minimum=0,
        maximum=1,
        config=False,
    )
    rerun_margin: float = knob(
        1.2,
        "A re-measurement at another order searches the chosen rate's range widened by this factor (step 6).",
        minimum=1,
        config=False,
    )
    rescue_tries: int = knob(
        3,
        "Where the lines found no comb, how many of the screen's likeliest rates are measured again.",
        minimum=0,
        config=False,
    )
    ratios: tuple = knob(
        (1 / 3, 1 / 2, 2 / 3, 1.0, 3 / 2, 2.0, 3.0),
        "The standard ratios to the estimate's rate that are always examined (with 1/B and B).",
        config=False,
    )
    # the fixed settings of the set-up's plausibility checks that read the recording
    # (rotors.plausibility; not the resolver's, not in info["order"]["settings"])
    track_speed_tol_mps: float = knob(
        1.0,
        "Plausibility checks: how well a track's radial velocity is trusted [m/s] (a tracker's range rate): the "
        "body line and the track's Doppler -2 v / lambda disagree only beyond it.",
        minimum=0,
        config=False,
    )
    segment_s: float = knob(
        0.1,
        "Plausibility checks: segments of the time-averaged spectrum are this long [s] (a power of two of "
        "pulses, 256-4096) ...",
        exclusive_minimum=0,
        config=False,
    )
    max_segments: int = knob(64, "... at most this many, evenly spread over the recording.", minimum=1, config=False)

    def __post_init__(self):
        check_ranges(self, "rotors.order", all_fields=True)  # the config=False knobs' ranges
        if not 0 < self.min_rev_s < self.max_rev_s:
            raise ValueError(f"min_rev_s={self.min_rev_s}, max_rev_s={self.max_rev_s} must satisfy 0 < min < max")
        lo, hi = self.extent_range
        if not 0 < lo < hi:
            raise ValueError(f"extent_range={self.extent_range} must satisfy 0 < low < high")
        for name in (
            "depart_max",
            "max_tip_mach",
            "line_sd_db",
            "spurious_per_cpi",
            "spurious_range_db",
            "temperature",
            "screen_step",
        ):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name}={getattr(self, name)} must be > 0")
        if not 0 <= self.fade < 1:
            raise ValueError(f"fade={self.fade} must be in [0, 1)")
        if not self.report_at <= self.ambiguous_at <= 1:
            raise ValueError(f"ambiguous_at={self.ambiguous_at} must be in [{self.report_at} (report_at), 1]")
        if not self.tip_speed_mps > 0 or not self.tip_speed_log_sd >= 0:
            raise ValueError(
                f"tip_speed_mps={self.tip_speed_mps} must be > 0 and tip_speed_log_sd={self.tip_speed_log_sd} >= 0"
            )
        if self.screen_keep < 0:
            raise ValueError(f"screen_keep={self.screen_keep} must be >= 0")
        if not self.ratios or any(not r > 0 for r in self.ratios):
            raise ValueError(f"ratios={self.ratios} must be a non-empty tuple of numbers > 0")


#: OrderConfig's fields that ``info["order"]["settings"]`` does not list (never did:
#: ``ratios`` was a module constant, the rest are the plausibility checks')
NOT_STORED = ("ratios", "track_speed_tol_mps", "segment_s", "max_segments")


def stored_settings(ocfg: OrderConfig) -> dict:
    """``info["order"]["settings"]``: the fields of ``ocfg`` but :data:`NOT_STORED`, by
    name (the fixed ones after the others, as when they were module constants: the
    stored dict, and so ``benchmarks/order_fingerprint.py``'s full hash, stay as they
    were)."""
    return {k: v for k, v in asdict(ocfg).items() if k not in NOT_STORED}


def rho_max(n_blades: int, weak_db: float) -> float:
    """Largest ratio of a rotation-rate line to a blade-passing line at the same
    Doppler: one blade of amplitude g = 10^(-weak_db/20) among B - 1 of amplitude 1
    gives |1 - g| / (B - 1 + g) (the k-th harmonic's blade sum for k not a multiple of B)."""
    g = 10 ** (-weak_db / 20)
    return (1 - g) / (n_blades - 1 + g)


@dataclass
class _Data:
    """The CPIs' peaks and geometry (Hz relative to the body, per CPI)."""

    prf: float
    bin_hz: float
    n_fft: int
    peaks_x: np.ndarray  # [n_cpi, P] peak offset from the body [Hz], NaN padding
    peaks_y: np.ndarray  # [n_cpi, P] height over the floor [dB]
    pk_table: list  # sparse table of peak heights, CPIs concatenated (each doubled: circular)
    masked: np.ndarray  # [n_cpi, 2 n_fft + 1] prefix counts of masked bins (doubled, circular)
    centre_bin: np.ndarray  # [n_cpi] body [fractional bin, 0..n_fft)
    p_lo: np.ndarray  # [n_cpi] slowest rotor's rate / reference
    p_hi: np.ndarray  # [n_cpi] fastest rotor's rate / reference
    cpi_index: np.ndarray  # which CPIs of the estimate
    band_hz: np.ndarray  # [n_cpi] analysed offsets |x| <= band (the comb's harmonics resolved)
    extent_hz: float  # the blade energy's Doppler extent: how far lines reach (a lower bound)
    top_db: float = np.inf  # the strongest line over the floor (per CPI, the median over CPIs) [dB]


def _sparse_table(v: np.ndarray) -> list:
    out = [v]
    j = 1
    while 2 * j <= len(v):
        prev = out[-1]
        out.append(np.maximum(prev[: len(prev) - j], prev[j:]))
        j *= 2
    return out


def _range_max(table: list, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """max v[lo..hi] (inclusive, lo <= hi) from a sparse table."""
    ln = np.maximum(hi - lo + 1, 1)
    lev = np.floor(np.log2(ln)).astype(int)
    out = np.full(lo.shape, -np.inf)
    for L in np.unique(lev):
        s = lev == L
        t = table[min(L, len(table) - 1)]
        out[s] = np.maximum(t[lo[s]], t[hi[s] - (1 << L) + 1])
    return out


def _row_median(r: np.ndarray) -> np.ndarray:
    """Median of the finite entries of each row (NaN where none)."""
    srt = np.sort(r, axis=1)  # NaN last
    cnt = np.isfinite(r).sum(axis=1)
    lo = np.clip((cnt - 1) // 2, 0, None)
    hi = np.clip(cnt // 2, 0, None)
    rows = np.arange(len(r))
    out = 0.5 * (srt[rows, np.minimum(lo, r.shape[1] - 1)] + srt[rows, np.minimum(hi, r.shape[1] - 1)])
    return np.where(cnt > 0, out, np.nan)


def _choose_cpis(valid: np.ndarray, k: int) -> np.ndarray:
    """Up to ``k`` of the valid CPIs, evenly spread, non-overlapping ones first."""
    idx = np.flatnonzero(valid)
    if len(idx) <= k:
        return idx
    even = idx[idx % 2 == 0]
    pool = even if len(even) >= k else idx
    return pool[np.round(np.linspace(0, len(pool) - 1, k)).astype(int)]


def _prepare(flight, est, cpis: np.ndarray, ref: float, ocfg: OrderConfig, scfg) -> _Data:
    n = int(est.n_fft)
    hop = n // 2
    prf = float(flight.prf_hz)
    bin_hz = prf / n
    f = np.fft.fftfreq(n, 1 / prf)
    P = []
    px, py, tabs, masks, cb = [], [], [], [], []
    # the kernel's transform; the power as |X|^2 (not re^2 + im^2: the same to 1 ulp,
    # kept so that the peaks, and the orders judged on them, stay what they were)
    X = stft(flight.iq, n, starts=np.asarray(cpis, np.int64) * hop)
    energy = (window(n) ** 2).sum()
    for i, Xi in zip(cpis, X):
        p = np.abs(Xi) ** 2 / energy
        pdb = np.fft.fftshift(10 * np.log10(p + 1e-30))
        fl = local_floor_db(pdb[None, :])[0]
        z = np.fft.ifftshift(pdb - fl)
        body = float(est.body_hz[i])
        rel = (f - body + prf / 2) % prf - prf / 2
        mask = (np.abs(f) < ocfg.clutter_guard_hz) | (np.abs(rel) < ocfg.body_guard_hz)
        z = np.where(mask, -100.0, z)
        pad = 8
        zz = np.r_[z[-pad:], z, z[:pad]]
        pk, _ = find_peaks(zz, height=ocfg.line_db, prominence=ocfg.prominence_db)
        pk = pk[(pk >= pad) & (pk < pad + n)]
        # parabolic refinement of each peak's bin
        a, b, c = zz[pk - 1], zz[pk], zz[pk + 1]
        den = a - 2 * b + c
        off = np.where(den < 0, np.clip(0.5 * (a - c) / np.where(den < 0, den, -1), -0.5, 0.5), 0.0)
        pos = (pk - pad + off) % n
        cbin = (body / bin_hz) % n
        xr = ((pos - cbin + n / 2) % n - n / 2) * bin_hz
        px.append(xr)
        py.append(b)
        hv = np.full(n, -np.inf)
        hv[pk - pad] = b
        tabs.append(np.r_[hv, hv])
        masks.append(np.r_[0, np.cumsum(np.r_[mask, mask])])
        cb.append(cbin)
        P.append(len(pk))
    Pm = max(max(P) if P else 0, 1)
    peaks_x = np.full((len(cpis), Pm), np.nan)
    peaks_y = np.full((len(cpis), Pm), np.nan)
    for r, (x, y) in enumerate(zip(px, py)):
        peaks_x[r, : len(x)] = x
        peaks_y[r, : len(y)] = y
    sp = np.asarray(est.speeds_rev_s[cpis], float)
    # a rotor put on another order's line (over 15 % from the CPI's median rotor) is no
    # part of the spread
    med = np.nanmedian(sp, axis=1, keepdims=True)
    raw, sp = sp, np.where(np.abs(sp / med - 1) <= 0.15, sp, np.nan)
    # a CPI with as many rotors on one order's lines as on another's has no rotor near
    # its median: there the rotors within 15 % of the comb's rate, else the rate alone
    # (without it the spread is NaN and the order goes unjudged)
    empty = ~np.isfinite(sp).any(axis=1)
    if empty.any():
        near = np.where(np.abs(raw[empty] / ref - 1) <= 0.15, raw[empty], np.nan)
        sp[empty] = np.where(np.isfinite(near).any(axis=1, keepdims=True), near, ref)
    p_lo = np.nanmin(sp, axis=1) / ref
    p_hi = np.nanmax(sp, axis=1) / ref
    # the rotor spread seen in the data: peaks within 12 % of the comb's first three
    # blade-passing harmonics (where no other order's line falls); the estimate may have
    # put two rotors on one line and missed the fastest or slowest
    fb = int(est.n_blades) * ref
    ax = np.abs(peaks_x)
    nn = np.round(ax / fb)
    dev = np.where((nn >= 1) & (nn <= 3) & (peaks_y >= ocfg.line_db + 3.0), ax / np.maximum(nn, 1) / fb - 1, np.nan)
    dev = np.where(np.abs(dev) <= 0.12, dev, np.nan)
    with np.errstate(all="ignore"):
        has = np.isfinite(dev).any(axis=1)
        p_lo = np.where(has, np.minimum(p_lo, 1 + np.nanmin(np.where(has[:, None], dev, 0.0), axis=1)), p_lo)
        p_hi = np.where(has, np.maximum(p_hi, 1 + np.nanmax(np.where(has[:, None], dev, 0.0), axis=1)), p_hi)
    mid = 0.5 * (p_lo + p_hi)
    half = np.minimum(0.5 * (p_hi - p_lo), 0.1 * mid) + ocfg.spread_margin * mid  # (over 20 %: not one drone's)
    # the blade energy's extent: per CPI the M-th farthest line (M rotors), the median
    # over CPIs (folded lines put it at the band's edge: a lower bound of the extent)
    far = []
    for x, y in zip(px, py):
        a = np.sort(np.abs(x[y >= ocfg.line_db + 3.0]))
        if len(a):
            far.append(a[-min(len(a), int(est.n_motors))])
    extent = float(np.median(far)) if far else 0.0
    tops = [float(np.max(y)) for y in py if len(y)]
    top = float(np.median(tops)) if tops else np.inf
    # the analysed band: where the rotation harmonics' windows of the lines' comb stay
    # apart (beyond, the rotors' lines merge into a continuum that tells no order)
    band = np.minimum(0.5 / (half / mid + 0.004) * ref * mid, prf / 2)
    peaks_x = np.where(np.abs(peaks_x) <= band[:, None], peaks_x, np.nan)
    peaks_y = np.where(np.isfinite(peaks_x), peaks_y, np.nan)
    return _Data(
        prf,
        bin_hz,
        n,
        peaks_x,
        peaks_y,
        _sparse_table(np.concatenate(tabs)),
        np.array(masks),
        np.array(cb),
        mid - half,
        mid + half,
        np.asarray(cpis),
        band,
        extent,
        top,
    )


@dataclass
class _Geometry:
    """Windows and peak assignments of one candidate rate (arrays over the CPIs)."""

    f: float
    d: np.ndarray  # [n_cpi, W] unfolded offset of the outermost rotor's line [Hz]
    fam: np.ndarray  # [n_cpi, W] True: rotation-rate family (k not a multiple of B)
    valid: np.ndarray  # [n_cpi, W] window observable (centre unmasked)
    detected: np.ndarray  # [n_cpi, W] a peak inside
    fmax: np.ndarray  # [n_cpi] blade-tip Doppler of the fastest rotor [Hz]
    tail: np.ndarray  # [n_cpi] the edge's allowance beyond kappa fmax [Hz]
    tail_width: np.ndarray  # [n_cpi] (beta / 2)^(1/3) rotation harmonics of the fastest rotor [Hz]
    pk_d: np.ndarray  # [n_cpi, P, 2] per peak: offset d of the covering window, per family (inf: none)
    pk_w: np.ndarray  # [n_cpi, P, 2] its width [Hz]
    pk_y: np.ndarray  # [n_cpi, P]
    pk_ok: np.ndarray  # [n_cpi, P]
    lo_bin: np.ndarray  # [n_cpi, W] first bin of each window (mod n_fft)
    hi_bin: np.ndarray  # [n_cpi, W] last bin (lo_bin + width, may pass n_fft)
    band: np.ndarray  # [n_cpi] analysed offsets |x| <= band [Hz]


def _geometry(
    data: _Data, f: float, B: int, L: float | None, lam: float, ocfg: OrderConfig, rows: np.ndarray | None = None
) -> _Geometry:
    rows = np.arange(len(data.p_lo)) if rows is None else rows
    prf, bh, n = data.prf, data.bin_hz, data.n_fft
    lo, hi = f * data.p_lo[rows], f * data.p_hi[rows]  # [R] Hz per harmonic
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    kmax_ext = ocfg.extent_range[1]
    if L is not None:
        fmax = 4 * np.pi * hi * L / lam
        # the lines of a point at the tip, J_k(beta) with beta = 4 pi L / lambda, fall off
        # over ~beta^(1/3) harmonics beyond k = beta: the edge's allowance
        tail = ocfg.tail_harmonics * (4 * np.pi * L / lam) ** (1 / 3) * hi
        tail_width = (2 * np.pi * L / lam) ** (1 / 3) * hi
        dmax = kmax_ext * fmax + tail
    else:
        fmax = np.full(len(rows), np.inf)
        tail = np.zeros(len(rows))
        tail_width = np.ones(len(rows))
        dmax = np.full(len(rows), prf)
    K = int(np.clip(np.ceil(np.max(dmax / lo)), 1, 4000))
    k = np.arange(1, K + 1)
    # windows: [R, 2K] (k for s = +1 then s = -1)
    kk = np.r_[k, k][None, :].astype(float)
    s = np.r_[np.ones(K), -np.ones(K)][None, :]
    hw = np.minimum(kk * (half[:, None] + 0.004 * mid[:, None]) + 1.5 * bh, 0.5 * mid[:, None])
    centre = kk * mid[:, None]
    d = kk * hi[:, None]
    inrange = d <= dmax[:, None]
    cbin = data.centre_bin[rows][:, None] + s * centre / bh
    lo_b = np.floor(cbin - hw / bh).astype(np.int64)
    hi_b = np.ceil(cbin + hw / bh).astype(np.int64)
    width_b = np.minimum(hi_b - lo_b, n - 1)
    lo_m = lo_b % n
    hi_m = lo_m + width_b
    base = (rows * 2 * n)[:, None]
    det = np.isfinite(_range_max(data.pk_table, lo_m + base, hi_m + base))
    cm = np.round(cbin).astype(np.int64) % n
    msk = data.masked[rows]
    centre_masked = (np.take_along_axis(msk, cm + 1, 1) - np.take_along_axis(msk, cm, 1)) > 0
    folded = np.abs((s * centre + prf / 2) % prf - prf / 2)
    valid = inrange & ~centre_masked & (folded <= data.band_hz[rows][:, None])
    fam = (np.r_[k, k] % B != 0)[None, :].repeat(len(rows), 0)
    # peaks: the covering window of each family, over the folds
    x = data.peaks_x[rows]  # [R, P]
    ok = np.isfinite(x)
    J = int(np.ceil(np.max(dmax) / prf)) + 1
    js = np.arange(-J, J + 1)
    xj = np.where(ok, x, 0.0)[:, :, None] + js[None, None, :] * prf  # [R, P, 2J+1]
    ax = np.abs(xj)
    pk_d = np.full(x.shape + (2,), np.inf)
    pk_w = np.full(x.shape + (2,), np.inf)
    m_ = mid[:, None, None]
    # the nearest harmonic and its neighbours (windows widen with k and may reach over)
    kf = np.round(ax / m_)[..., None] + np.array([-1.0, 0.0, 1.0])  # [R, P, 2J+1, 3]
    kf = kf.reshape(ax.shape[:2] + (-1,))
    ax = np.repeat(ax, 3, axis=2)
    kf_ok = (kf >= 1) & (kf <= K)
    hwk = np.minimum(kf * (half[:, None, None] + 0.004 * m_) + 1.5 * bh, 0.5 * m_)
    inside = kf_ok & (np.abs(ax - kf * m_) <= hwk) & (kf * hi[:, None, None] <= dmax[:, None, None])
    dd = np.where(inside, kf * hi[:, None, None], np.inf)
    famk = (kf.astype(np.int64) % B) != 0
    for fi, fsel in enumerate((~famk, famk)):
        dsel = np.where(fsel, dd, np.inf)
        j = np.argmin(dsel, axis=2)
        pk_d[:, :, fi] = np.take_along_axis(dsel, j[:, :, None], 2)[:, :, 0]
        wsel = np.take_along_axis(np.where(fsel & inside, 2 * hwk, np.inf), j[:, :, None], 2)[:, :, 0]
        pk_w[:, :, fi] = wsel
    return _Geometry(
        f,
        d,
        fam,
        valid,
        det,
        fmax,
        tail,
        tail_width,
        pk_d,
        pk_w,
        data.peaks_y[rows],
        ok,
        lo_m,
        hi_m,
        data.band_hz[rows],
    )


def _envelope(y: np.ndarray, d: np.ndarray, ex: np.ndarray, floor_db: float) -> tuple[np.ndarray, float]:
    """Line level a per CPI [dB] and decay beta [dB/Hz] (one for all CPIs) by least
    squares on the explained peaks (heights ``y`` at offsets ``d``, mask ``ex``, [R, P]);
    CPIs without a peak get ``floor_db``."""
    n = ex.sum(axis=1)
    with np.errstate(all="ignore"):
        dm = np.where(n > 0, (d * ex).sum(axis=1) / n, 0.0)
        ym = np.where(n > 0, (y * ex).sum(axis=1) / n, 0.0)
    dc = np.where(ex, d - dm[:, None], 0.0)
    sxx = float((dc**2).sum())
    sxy = float((dc * np.where(ex, y - ym[:, None], 0.0)).sum())
    beta = max(0.0, -sxy / sxx) if sxx > 0 else 0.0
    return np.where(n > 0, ym + beta * dm, floor_db), beta


_AI0 = float(airy(0.0)[0])


def _tail_fall_db(d: np.ndarray, lim0: np.ndarray, width: np.ndarray) -> np.ndarray:
    """How far [dB] a line at offset ``d`` beyond ``lim0`` (kappa f_max) falls below the
    envelope: the tip's Bessel lines J_k(beta) beyond k = beta follow the Airy function,
    (2 / k)^(1/3) Ai((2 / k)^(1/3) (k - beta)), so over ``width`` = (beta / 2)^(1/3)
    harmonics [Hz] the level falls as Ai(m) / Ai(0) (8 dB at m = 1, 20 dB at m = 2)."""
    m = np.clip((d - lim0) / width, 0.0, 8.0)
    return np.where(d > lim0, -20 * np.log10(np.maximum(airy(m)[0], 1e-300) / _AI0), 0.0)


def _tail_reach_m(fall_db: float) -> float:
    """The offset m (in (beta / 2)^(1/3) rotation harmonics beyond kappa f_max) at which
    the tip's fall-off (:func:`_tail_fall_db`) reaches ``fall_db``: how far beyond the
    tips' Doppler a line can stand that much under the strongest one."""
    if not np.isfinite(fall_db):
        return np.inf
    m = np.linspace(0.0, 8.0, 1601)
    fall = -20 * np.log10(np.maximum(airy(m)[0], 1e-300) / _AI0)
    return float(m[min(np.searchsorted(fall, max(fall_db, 0.0)), len(m) - 1)])


def _loglik(
    g: _Geometry,
    ocfg: OrderConfig,
    kappas,
    rho_cap_db: float,
    rho_modes,
    beta_mults,
    a_offsets,
    per_cpi=False,
    with_cpis=False,
):
    """Maximised log-likelihood of a candidate: (LL, params), (LL, params, per-CPI LL)
    where ``with_cpis``, or the per-CPI LL of the best parameters where ``per_cpi``.

    Over a grid of kappa (``kappas``) and of the rotation-rate family (``rho_modes``:
    None, absent; "fit", its level from its peaks, at most ``rho_cap_db``); the level per
    CPI and the decay by least squares on the explained blade-passing peaks, then
    varied by ``beta_mults`` and ``a_offsets`` (the detected peaks bias both)."""
    T, sd = ocfg.line_db, ocfg.line_sd_db
    log_keep = np.log1p(-ocfg.fade)
    log_norm = np.log(sd * np.sqrt(2 * np.pi))
    # a peak no line explains lies anywhere in the analysed band (+-band: only its peaks
    # are observed) and its height anywhere over ``spurious_range_db``
    spur = np.log(ocfg.spurious_per_cpi / (2 * g.band[:, None]) / ocfg.spurious_range_db)
    y = np.where(g.pk_ok, g.pk_y, 0.0)
    pd_b = np.where(np.isfinite(g.pk_d[:, :, 0]), g.pk_d[:, :, 0], 0.0)
    pd_i = np.where(np.isfinite(g.pk_d[:, :, 1]), g.pk_d[:, :, 1], 0.0)
    lw_b = -np.log(np.where(np.isfinite(g.pk_w[:, :, 0]), g.pk_w[:, :, 0], 1.0))
    lw_i = -np.log(np.where(np.isfinite(g.pk_w[:, :, 1]), g.pk_w[:, :, 1], 1.0))
    fmax = g.fmax[:, None]
    best = (-np.inf, None, None)
    for kap in kappas:
        lim = kap * fmax + g.tail[:, None]
        act_w = g.valid & (g.d <= lim)
        # a window in the tail (beyond kappa f_max) expects the tip's fall-off
        fall_w = _tail_fall_db(g.d, kap * fmax, g.tail_width[:, None]) if ocfg.tail_fall else 0.0
        ex_b = g.pk_ok & (g.pk_d[:, :, 0] <= lim)
        a_fit, beta_fit = _envelope(y, pd_b, ex_b, T - 2 * sd)
        for mode in rho_modes:
            use_imb = mode is not None
            ex_i = g.pk_ok & use_imb & (g.pk_d[:, :, 1] <= lim)
            rho = 0.0
            a_use, d_lev = a_fit, np.where(ex_b, pd_b, 0.0).sum(1) / np.maximum(ex_b.sum(1), 1)
            if use_imb:
                only = ex_i & ~ex_b
                if ocfg.rotation_level:
                    has_b = ex_b.any(axis=1)
                    r = (y - (a_fit[:, None] - beta_fit * pd_i))[only & has_b[:, None]]
                    rho = float(np.clip(np.median(r), rho_cap_db - 20, rho_cap_db)) if r.size else rho_cap_db
                    # a CPI whose explained peaks are all of the rotation-rate family (its
                    # blade-passing lines beyond the analysed band, faded or masked) has
                    # its level from them: the blade-passing lines above them by 1 / rho
                    rot = only & ~has_b[:, None]
                    n_r = rot.sum(axis=1)
                    with np.errstate(all="ignore"):
                        a_rot = np.where(rot, y + beta_fit * pd_i, 0.0).sum(axis=1) / np.maximum(n_r, 1) - rho
                    a_use = np.where(n_r > 0, a_rot, a_fit)
                    d_lev = np.where(n_r > 0, np.where(rot, pd_i, 0.0).sum(1) / np.maximum(n_r, 1), d_lev)
                else:
                    r = (y - (a_fit[:, None] - beta_fit * pd_i))[only]
                    rho = float(np.clip(np.median(r), rho_cap_db - 20, rho_cap_db)) if r.size else rho_cap_db - 20
            w_act = act_w & (~g.fam | use_imb)
            miss = w_act & ~g.detected
            for bm in beta_mults:
                beta = beta_fit * bm
                a0 = a_use + (beta - beta_fit) * d_lev
                shp_b = -beta * pd_b
                shp_i = -beta * pd_i + rho
                shp_w = -beta * g.d + np.where(g.fam, rho, 0.0) - fall_w
                for ao in a_offsets:
                    a = (a0 + ao)[:, None]
                    lb = np.where(ex_b, log_keep - 0.5 * ((y - a - shp_b) / sd) ** 2 - log_norm + lw_b, -np.inf)
                    li = np.where(ex_i, log_keep - 0.5 * ((y - a - shp_i) / sd) ** 2 - log_norm + lw_i, -np.inf)
                    lp = np.where(g.pk_ok, np.maximum(np.maximum(lb, li), spur), 0.0).sum(axis=1)
                    pdet = np.exp(log_keep + log_ndtr((a + shp_w - T) / sd))
                    lm = np.where(miss, np.log1p(-np.minimum(pdet, 1 - 1e-12)), 0.0).sum(axis=1)
                    tot = lp + lm
                    s_ = float(tot.sum())
                    if s_ > best[0]:
                        best = (s_, (kap, beta, rho if use_imb else None, a0 + ao), tot)
    if per_cpi:
        return best[2]
    kap, beta, rho, a = best[1]
    params = {
        "kappa": float(kap),
        "decay_db_per_khz": float(1e3 * beta),
        "imbalance_db": None if rho is None else float(rho),
        "level_db": float(np.median(a)),
    }
    return (best[0], params, best[2]) if with_cpis else (best[0], params)


@dataclass
class Candidate:
    """One candidate rotation rate and its score."""

    rev_s: float
    ratio: float
    loglik: float
    params: dict
    tip_mach: float
    extent_ratio: float
    explained_share: float
    origin: str
    coverage: float = 0.0
    per_cpi: np.ndarray = field(default_factory=lambda: np.zeros(0))
    relative_likelihood: float = 0.0


def _coverage(g: _Geometry, params: dict, data: _Data) -> float:
    """Share of the analysed band's bins inside the candidate's active line windows (the
    chance that a peak anywhere in it is explained: near 1 the comb tells little)."""
    n = data.n_fft
    act = (
        g.valid
        & (g.d <= params["kappa"] * g.fmax[:, None] + g.tail[:, None])
        & (~g.fam | (params["imbalance_db"] is not None))
    )
    R = act.shape[0]
    diff = np.zeros((R, 2 * n + 2))
    rr = np.repeat(np.arange(R)[:, None], act.shape[1], 1)[act]
    np.add.at(diff, (rr, g.lo_bin[act]), 1)
    np.add.at(diff, (rr, np.minimum(g.hi_bin[act] + 1, 2 * n + 1)), -1)
    cov = np.cumsum(diff, axis=1)[:, : 2 * n] > 0
    cov = cov[:, :n] | cov[:, n:]
    rows = np.arange(R) if R == len(data.band_hz) else None
    x = ((np.arange(n)[None, :] - data.centre_bin[rows][:, None] + n / 2) % n - n / 2) * data.bin_hz
    inband = np.abs(x) <= data.band_hz[rows][:, None]
    return float(cov[inband].mean()) if inband.any() else 0.0


def _explained(g: _Geometry, params: dict) -> tuple[float, float]:
    """(share of peaks explained, the blade flash's extent over f_max: the 90th
    percentile over CPIs of the farthest explained blade-family line)."""
    lim = params["kappa"] * g.fmax[:, None] + g.tail[:, None]
    ex_b = g.pk_ok & (g.pk_d[:, :, 0] <= lim)
    ex_i = g.pk_ok & (params["imbalance_db"] is not None) & (g.pk_d[:, :, 1] <= lim)
    share = float((ex_b | ex_i).sum() / max(g.pk_ok.sum(), 1))
    far = np.where(ex_b, g.pk_d[:, :, 0], 0.0).max(axis=1)
    ext = float(np.percentile(far / g.fmax, 90)) if np.all(np.isfinite(g.fmax)) and len(far) else float("nan")
    return share, ext


def _score(
    data: _Data,
    f: float,
    B: int,
    L,
    lam: float,
    ocfg: OrderConfig,
    grid_full: tuple,
    ref: float,
    p_top: float,
    origin: str,
) -> Candidate:
    """The full model's score of rate ``f``: log-likelihood (over ``temperature``), the
    fitted envelope, per-CPI log-likelihoods, the blades' tip Mach, extent and coverage."""
    g = _geometry(data, f, B, L, lam, ocfg)
    ll, params, per = _loglik(g, ocfg, *grid_full, with_cpis=True)
    share, ext = _explained(g, params)
    return Candidate(
        float(f),
        float(f / ref),
        float(ll) / ocfg.temperature,
        params,
        float(2 * np.pi * f * p_top * L / SOUND_MPS) if L is not None else float("nan"),
        ext,
        share,
        origin,
        _coverage(g, params, data),
        per / ocfg.temperature,
    )


def _relative(best: Candidate, c: Candidate, ocfg: OrderConfig) -> float:
    """Likelihood of ``c`` relative to ``best``, tempered twice: by the CPIs' own scatter
    (the per-CPI differences d_i have variance ~2 mean(d) where the model holds; a larger
    scatter scales the evidence down by 2 mean / variance), and by the share of the
    spectrum the two combs' windows cover (a peak is explained by chance there: the
    evidence is scaled by (1 - coverage) / (1 - ``coverage_free``), at least
    ``min_evidence``)."""
    if c is best:
        return 1.0
    d = best.per_cpi - c.per_cpi
    total = best.loglik - c.loglik
    if total <= 0:
        return 1.0
    if len(d) > 1:
        mu, var = float(d.mean()), float(d.var(ddof=1))
        if mu > 0 and var > 2 * mu:
            total *= 2 * mu / var
    cov = max(best.coverage, c.coverage)
    total *= float(np.clip((1 - cov) / (1 - ocfg.coverage_free), ocfg.min_evidence, 1.0))
    return float(np.exp(-total))


@dataclass
class _Comb:
    """The lines' comb (step 1) and what every candidate rate is judged against."""

    B: int  # blades per rotor (the estimate's)
    L: float | None  # blade length [m]; None where unknown
    lam: float  # wavelength [m]
    ref: float  # the comb's rate: the median rotor [rev/s]
    cpis: np.ndarray  # the CPIs used
    data: _Data
    p_top: float  # the fastest rotor's rate over the comb's, the largest over CPIs
    p_mid_hi: float  # the same, the median over CPIs
    beta: float | None  # 4 pi L / lambda
    tail_h: float  # the tail beyond kappa f_max [rotation harmonics] (step 3)
    rmax_db: float  # the rotation-rate family's largest level [dB] (step 4)
    grid_full: tuple  # the line model's grid: kappas, rmax_db, rho modes, decay factors, level offsets


@dataclass
class _Choice:
    """The candidates weighed (step 5): the chosen one first."""

    cands: list  # [Candidate], the chosen one first
    log_prior: np.ndarray  # the tip speed's log prior of each
    chosen: Candidate
    likeliest: Candidate  # the largest relative likelihood (without the prior)
    rate: float  # the chosen rate [rev/s] (refined on a finer grid where the screen found it)


@dataclass
class _Speeds:
    """The speeds at the chosen order (step 6)."""

    est: object  # RotorEstimate
    how: str  # kept, measured again, or the lines' estimate scaled
    n_moved: int  # rotor-CPIs moved to the median
    method_diff: np.ndarray | None
    mean_rev_s: float  # the speeds' median over CPIs (the chosen rate where split)
    as_measured: float  # the same before the split's scaling
    depart: float  # log of as_measured over the chosen rate
    split: bool


@dataclass
class _Doubt:
    """The order's doubt: the plausible alternatives and what is listed."""

    var_rel: float  # relative variance of the mixture about the reported speed
    ambiguous: bool
    alternatives_rev_s: list
    relative_likelihood: list
    posterior_odds: list


def _blade_length(flight) -> float | None:
    L = flight.attrs.get("blade_length_m")
    return float(L) if L is not None and float(L) > 0 else None


def _screen_grid(ocfg: OrderConfig) -> np.ndarray:
    """The screen's rates: ``min_rev_s``-``max_rev_s`` in log steps of ``screen_step``."""
    return np.exp(np.arange(np.log(ocfg.min_rev_s), np.log(ocfg.max_rev_s), ocfg.screen_step))


def _screen_scores(data: _Data, grid, B, L, lam, ocfg: OrderConfig, rmax_db, kappas, rows=None) -> np.ndarray:
    """The coarse model's log-likelihood of each rate of ``grid`` (kappa over ``kappas``,
    the rotation-rate family fitted, no decay or level variations) on the CPIs ``rows``."""
    sc = np.full(len(grid), -np.inf)
    for gi, f in enumerate(grid):
        g = _geometry(data, f, B, L, lam, ocfg, rows)
        sc[gi] = _loglik(g, ocfg, kappas, rmax_db, (None, "fit"), (1.0,), (-3.0,))[0]
    return sc


def _lines_to_judge(est, speed_config, rerun):
    """Step 1: the lines alone (steps 1-8 of the estimator) measure the comb's spacing; an
    I/Q fit made at a wrong order is biased, so the order is judged on the lines."""
    if getattr(speed_config, "refine", False) and rerun is not None:
        lines = rerun(replace(speed_config, refine=False))
        if lines.ok and lines.valid.any():
            return lines
    return est


def _comb(flight, lines, B: int, ocfg: OrderConfig, speed_config) -> _Comb:
    """Step 1: the comb's rate (the median rotor: robust to a rotor put on another
    order's line), the CPIs' peaks and rotor spread (:func:`_prepare`), and the tail's
    reach beyond the tips' Doppler (step 3)."""
    L = _blade_length(flight)
    lam = C_MPS / float(flight.carrier_hz)
    ref = float(np.nanmedian(np.nanmedian(lines.speeds_rev_s[lines.valid], axis=1)))
    cpis = _choose_cpis(lines.valid, ocfg.max_cpis)
    data = _prepare(flight, lines, cpis, ref, ocfg, speed_config)
    beta = 4 * np.pi * L / lam if L is not None else None
    tail_h = ocfg.tail_harmonics * beta ** (1 / 3) if L is not None else 0.0
    if L is not None and ocfg.tail_level:
        tail_h = min(tail_h, _tail_reach_m(data.top_db - ocfg.line_db - 3.0 + ocfg.line_sd_db) * (beta / 2) ** (1 / 3))
    rmax_db = 20 * np.log10(rho_max(B, ocfg.max_weak_blade_db))
    kappas = np.round(np.arange(ocfg.extent_range[0], ocfg.extent_range[1] + 1e-9, 0.1), 3) if L is not None else (1.0,)
    return _Comb(
        B,
        L,
        lam,
        ref,
        cpis,
        data,
        float(np.max(data.p_hi)),
        float(np.median(data.p_hi)),
        beta,
        tail_h,
        rmax_db,
        (kappas, rmax_db, (None, "fit"), (0.6, 1.0, 1.5), (-4.0, 0.0)),
    )


def _physical(f: float, comb: _Comb, ocfg: OrderConfig) -> bool:
    """Step 3: a rate in range, blade tips below ``max_tip_mach``, and a blade-tip Doppler
    that the lines do not pass (lines beyond it are impossible)."""
    if not ocfg.min_rev_s <= f <= ocfg.max_rev_s:
        return False
    if comb.L is None:
        return True
    reach = (ocfg.extent_range[1] * comb.beta + comb.tail_h) * f * comb.p_mid_hi
    return 2 * np.pi * f * comb.p_top * comb.L / SOUND_MPS <= ocfg.max_tip_mach and comb.data.extent_hz <= reach


def _screen(comb: _Comb, ocfg: OrderConfig) -> tuple[np.ndarray, np.ndarray]:
    """Step 2's screen: a coarse model on ``ocfg.screen_cpis`` CPIs over the physical rates of
    the whole range. Returns (rates, log-likelihoods)."""
    n = len(comb.cpis)
    rows = np.unique(np.round(np.linspace(0, n - 1, min(ocfg.screen_cpis, n))).astype(int))
    grid = _screen_grid(ocfg)
    grid = grid[[_physical(f, comb, ocfg) for f in grid]]
    kappas = (min(1.0, ocfg.extent_range[1]),) if comb.L is not None else (1.0,)
    return grid, _screen_scores(comb.data, grid, comb.B, comb.L, comb.lam, ocfg, comb.rmax_db, kappas, rows)


def _candidates(comb: _Comb, ocfg: OrderConfig) -> list[tuple[float, str]]:
    """Step 2: the comb's rate times the simple ratios (and 1/B, B), then the screen's
    ``screen_keep`` best local maxima away from them; physical ones only (step 3).
    Returns [(rate [rev/s], origin)]."""
    ratios = sorted(set(ocfg.ratios) | {1.0 / comb.B, float(comb.B)}, key=lambda r: abs(np.log(r)))
    cand = [(r * comb.ref, f"x{r:.3g}") for r in ratios if _physical(r * comb.ref, comb, ocfg)]
    grid, sc = _screen(comb, ocfg)
    n_screen = 0
    for gi in np.argsort(sc)[::-1]:
        if n_screen >= ocfg.screen_keep or not np.isfinite(sc[gi]):
            break
        if sc[gi] < max(sc[gi - 1] if gi > 0 else -np.inf, sc[gi + 1] if gi + 1 < len(sc) else -np.inf):
            continue  # not a local maximum
        f = float(grid[gi])
        # near a simple ratio of the lines' comb it is that ratio (measured by the lines),
        # and a screen maximum near a kept one is the same
        if any(abs(np.log(f / c)) <= (ocfg.snap_rel if how != "screen" else ocfg.min_separation) for c, how in cand):
            continue
        cand.append((f, "screen"))
        n_screen += 1
    return cand


def _scored(comb: _Comb, f: float, origin: str, ocfg: OrderConfig) -> Candidate:
    """Step 4: the full line model on every CPI used (:func:`_score`)."""
    return _score(comb.data, f, comb.B, comb.L, comb.lam, ocfg, comb.grid_full, comb.ref, comb.p_top, origin)


def _choose(cands: list, comb: _Comb, ocfg: OrderConfig) -> _Choice:
    """Step 5: the comb the lines were read as keeps ``prior_lines``; each candidate's
    likelihood relative to the likeliest, tempered (:func:`_relative`); the order is the
    largest relative likelihood times the tip speed's prior (the relative likelihoods are
    then taken against it). A rate the screen found is refined on a finer grid."""
    for c in cands:
        c.loglik += ocfg.prior_lines if c.origin == "x1" else 0.0
    cands.sort(key=lambda c: -c.loglik)
    chosen = cands[0]
    for c in cands:
        c.relative_likelihood = _relative(chosen, c, ocfg)
    lp = tip_log_prior(np.array([c.rev_s for c in cands]), comb.L, ocfg)
    pick = int(np.argmax(np.log(np.maximum([c.relative_likelihood for c in cands], 1e-300)) + lp))
    likeliest = chosen
    if pick:
        chosen = cands[pick]
        first = [pick] + [i for i in range(len(cands)) if i != pick]
        cands, lp = [cands[i] for i in first], lp[first]
        for c in cands:
            c.relative_likelihood = _relative(chosen, c, ocfg)
    rate = chosen.rev_s
    if chosen.origin == "screen":  # refined on a finer grid
        fine = [
            _scored(comb, f, chosen.origin, ocfg)
            for f in chosen.rev_s * np.exp(np.linspace(-1, 1, 7) * ocfg.screen_step)
        ]
        rate = max(fine, key=lambda c: c.loglik).rev_s
    return _Choice(cands, lp, chosen, likeliest, rate)


def _speeds(flight, est, lines, choice: _Choice, comb: _Comb, speed_config, rerun, ocfg: OrderConfig) -> _Speeds:
    """Step 6: the estimate stands where the chosen rate is the comb's, else it is measured
    again (:func:`_remeasure`); rotors far from the others go to the median
    (:func:`_within_spread`); speeds whose median departs from the chosen rate by more
    than ``depart_max`` are scaled to it (split)."""
    out, how = est, "kept"
    if choice.chosen.origin != "x1" or int(lines.n_blades) != comb.B:
        out, how = _remeasure(flight, est, lines, choice.rate / comb.ref, speed_config, rerun, ocfg)
        out = replace(out, n_blades=comb.B)
    # whatever the order, a rotor far from the others is no rotor of this drone
    out, n_moved = _within_spread(out, ocfg)
    # the difference between the methods (the lines alone against the I/Q fit, per rotor
    # rank over the CPIs both estimated) joins the recording mean's uncertainty
    method_diff = _method_difference(out, lines) if how == "kept" and lines is not est else None
    rate = choice.rate
    v = out.valid
    mean_now = float(np.nanmedian(out.common_rev_s[v])) if v.any() else rate
    # the speeds against the chosen rate (``depart_max``): rotors split between two rates'
    # lines keep the order's rate as plausible as theirs
    depart = float(np.log(mean_now / rate)) if mean_now > 0 and rate > 0 else 0.0
    split = bool(abs(depart) > ocfg.depart_max)
    as_measured = mean_now
    if split:  # the speeds scaled to the chosen rate (their median over CPIs)
        k = rate / mean_now
        out = replace(out)
        out.speeds_rev_s, out.speeds_std_rev_s = out.speeds_rev_s * k, out.speeds_std_rev_s * k
        out.common_rev_s, out.common_std_rev_s = out.common_rev_s * k, out.common_std_rev_s * k
        mean_now = rate
    return _Speeds(out, how, n_moved, method_diff, mean_now, as_measured, depart, split)


def _doubt(choice: _Choice, sp: _Speeds, ocfg: OrderConfig) -> _Doubt:
    """The order's doubt (module docstring): an alternative is plausible by its relative
    likelihood or by its posterior odds (the likelihood times the tip speed's prior,
    against the chosen one's: a rate the lines like less but whose tips turn at a typical
    speed stays named) at ``ambiguous_at`` or more (under it an alternative lies outside
    the mixture's 95 % interval and would only widen sigma for nothing); the plausible
    ones make the mixture's variance; those down to ``ocfg.report_at`` are listed."""
    kept, chosen, lp = choice.cands, choice.chosen, choice.log_prior
    odds = [c.relative_likelihood * float(np.exp(min(lp[i] - lp[0], 50.0))) for i, c in enumerate(kept)]
    plaus = [c for c, o in zip(kept, odds) if max(c.relative_likelihood, o) >= ocfg.ambiguous_at]
    wsum = sum(c.relative_likelihood for c in plaus)
    var_rel = sum(c.relative_likelihood / wsum * (c.rev_s / chosen.rev_s - 1) ** 2 for c in plaus)
    if sp.split:  # the equal mixture of the chosen rate and the speeds as measured
        var_rel += 0.5 * (sp.as_measured / choice.rate - 1) ** 2
    listed = [
        (c, o) for c, o in zip(kept[1:], odds[1:]) if c.relative_likelihood >= ocfg.report_at or o >= ocfg.ambiguous_at
    ]
    alts = [c for c, _ in listed]
    ambiguous = sp.split or any(max(c.relative_likelihood, o) >= ocfg.ambiguous_at for c, o in listed)
    alt_rev_s = [round(sp.mean_rev_s * c.rev_s / chosen.rev_s, 2) for c in alts]
    rel_l, post = [float(f"{c.relative_likelihood:.3g}") for c in alts], [float(f"{o:.3g}") for _, o in listed]
    if sp.split:
        alt_rev_s, rel_l, post = alt_rev_s + [round(sp.as_measured, 2)], rel_l + [1.0], post + [1.0]
    return _Doubt(var_rel, bool(ambiguous), alt_rev_s, rel_l, post)


def _widen(out, var_rel: float) -> None:
    """Every CPI's uncertainty includes the order's (in place): the mixture's spread about
    the reported speed."""
    out.common_std_rev_s = np.sqrt(out.common_std_rev_s**2 + var_rel * out.common_rev_s**2)
    out.speeds_std_rev_s = np.sqrt(out.speeds_std_rev_s**2 + var_rel * out.speeds_rev_s**2)


def _order_info(comb: _Comb, choice: _Choice, sp: _Speeds, doubt: _Doubt, ocfg: OrderConfig) -> dict:
    """``info["order"]``: the chosen rate, the alternatives and their doubt, the
    candidates, the settings."""
    chosen, likeliest, rate, L = choice.chosen, choice.likeliest, choice.rate, comb.L
    data, beta, mean_now, as_measured = comb.data, comb.beta, sp.mean_rev_s, sp.as_measured
    return {
        "method": METHOD,
        "chosen_rev_s": round(mean_now, 3),
        "lines_rev_s": round(comb.ref, 3),
        "ratio_to_lines": round(rate / comb.ref, 4),
        "remeasured": sp.how,
        "ambiguous": doubt.ambiguous,
        "alternatives_rev_s": doubt.alternatives_rev_s,
        "coverage": round(chosen.coverage, 3),
        "extent_hz": round(data.extent_hz, 1),
        "extent_over_tip_doppler": round(data.extent_hz / (beta * rate * comb.p_mid_hi), 3) if beta else None,
        "top_db": round(data.top_db, 1) if np.isfinite(data.top_db) else None,
        "tail_harmonics": round(comb.tail_h, 2) if L is not None else None,
        "relative_likelihood": doubt.relative_likelihood,
        "posterior_odds": doubt.posterior_odds,
        "departs": round(sp.depart, 4),
        "split": (
            f"the speeds as measured ({as_measured:.2f} rev/s) departed from the chosen rate {rate:.2f} "
            f"rev/s by {100 * (as_measured / rate - 1):+.1f} %: the rotors split between two rates' lines "
            f"({sp.n_moved} rotor-CPIs moved to the median); scaled to the chosen rate"
            if sp.split
            else None
        ),
        "tip_prior": (
            None
            if likeliest is chosen
            else f"the likeliest rate {mean_now * likeliest.rev_s / chosen.rev_s:.2f} rev/s (tip "
            f"{2 * np.pi * likeliest.rev_s * L:.0f} m/s) weighed against the tip speed's prior: "
            f"{2 * np.pi * chosen.rev_s * L:.0f} m/s is the more probable"
        ),
        "order_rel_std": float(np.sqrt(doubt.var_rel)),
        "n_rotors_to_median": int(sp.n_moved),
        "n_cpis": int(len(comb.cpis)),
        "candidates": [
            {
                **{
                    k: (round(v, 4) if isinstance(v, float) else v)
                    for k, v in asdict(c).items()
                    if k not in ("params", "per_cpi")
                },
                **c.params,
            }
            for c in choice.cands
        ],
        "settings": stored_settings(ocfg),
    }


def _report(comb: _Comb, choice: _Choice, sp: _Speeds, ocfg: OrderConfig):
    """The estimate at the chosen order with the order's doubt (:func:`_doubt`) in every
    CPI's uncertainty and ``info["order"]`` (:func:`_order_info`)."""
    doubt = _doubt(choice, sp, ocfg)
    out = sp.est
    _widen(out, doubt.var_rel)
    info = dict(out.info)
    if sp.method_diff is not None:
        info["method_diff_rev_s"] = [round(float(d), 3) for d in sp.method_diff]
    info["order"] = _order_info(comb, choice, sp, doubt, ocfg)
    out.info = info
    return out


def resolve_order(flight, est, speed_config, rerun=None, config: OrderConfig | None = None):
    """Choose the rotation rate's harmonic order for an estimate (module docstring).

    Parameters
    ----------
    flight : Flight
        The flight the estimate was made from.
    est : RotorEstimate
        :func:`microdoppler.rotors.speed.estimate_rotor_speeds`'s estimate (without
        order); returned unchanged where it has none.
    speed_config : RotorSpeedConfig
        The estimate's settings (floor, and the base of a re-measurement).
    rerun : callable(RotorSpeedConfig, n_blades=B) -> RotorEstimate, optional
        Measures the speeds again with other settings (the lines alone; the search
        confined to the chosen rate; the rotation-rate comb, ``n_blades=1``, where the
        blade-passing comb gave no estimate); without it a changed order scales the
        speeds.
    config : OrderConfig, optional

    Returns
    -------
    RotorEstimate
        With ``info["order"]`` (candidates, the chosen one, alternatives and their
        relative likelihood, whether the order is ambiguous) and uncertainties that
        include the order's; ``est`` itself where neither comb gives an estimate.
    """
    ocfg = config or OrderConfig()
    if not est.ok or not est.valid.any():
        # the lines found no comb; they may have followed a sub-harmonic path (unequal
        # blades, a first pair in the clutter band): screen the whole range and measure
        # again around the likeliest rates
        if rerun is None or est.reason is None or not est.reason.startswith(("no sideband", "no HERM")):
            return est
        return _rescue(flight, est, speed_config, rerun, ocfg)
    lines = _lines_to_judge(est, speed_config, rerun)  # 1. the lines
    comb = _comb(flight, lines, int(est.n_blades), ocfg, speed_config)
    cands = _candidates(comb, ocfg)  # 2. candidates, 3. physical ones
    if not cands:
        return est
    choice = _choose([_scored(comb, f, how, ocfg) for f, how in cands], comb, ocfg)  # 4. line model, 5. weighing
    sp = _speeds(flight, est, lines, choice, comb, speed_config, rerun, ocfg)  # 6. the speeds
    return _report(comb, choice, sp, ocfg)  # the order's doubt, info["order"]


def tip_log_prior(rev_s: np.ndarray, L, ocfg: OrderConfig) -> np.ndarray:
    """Log of the blade-tip speed's prior (``tip_speed_mps``, ``tip_speed_log_sd``) at
    rotation rates ``rev_s`` for blades of length ``L`` [m], up to a constant; zeros
    without a blade length or with ``tip_speed_log_sd`` = 0."""
    rev_s = np.asarray(rev_s, float)
    if L is None or ocfg.tip_speed_log_sd <= 0:
        return np.zeros_like(rev_s)
    z = np.log(2 * np.pi * rev_s * L / ocfg.tip_speed_mps) / ocfg.tip_speed_log_sd
    return -0.5 * z**2


def _rescue_rates(flight, est, scfg, ocfg: OrderConfig):
    """The screen's likeliest rates where the lines found no comb (the body from the
    track, rotors within +-``rescue_spread``, every CPI of ``ocfg.screen_cpis``), up to
    ``ocfg.rescue_tries`` of them at least ``rescue_rel`` apart, likeliest first."""
    from types import SimpleNamespace

    from ..spectra.snr import body_doppler_hz

    B = int(est.n_blades)
    L = _blade_length(flight)
    lam = C_MPS / float(flight.carrier_hz)
    body = body_doppler_hz(flight.track_time_s, flight.track_radial_velocity_mps, flight.wavelength_m, est.time_s)
    n = len(est.time_s)
    sp = np.tile(1 + np.linspace(-ocfg.rescue_spread, ocfg.rescue_spread, max(int(est.n_motors), 2)), (n, 1))
    pseudo = SimpleNamespace(n_fft=est.n_fft, body_hz=body, speeds_rev_s=sp, n_blades=B, n_motors=est.n_motors)
    cpis = _choose_cpis(np.ones(n, bool), ocfg.screen_cpis)
    data = _prepare(flight, pseudo, cpis, 1.0, ocfg, scfg)
    rmax_db = 20 * np.log10(rho_max(B, ocfg.max_weak_blade_db))
    grid = _screen_grid(ocfg)
    if L is not None:
        grid = grid[2 * np.pi * grid * (1 + ocfg.rescue_spread) * L / SOUND_MPS <= ocfg.max_tip_mach]
    sc = _screen_scores(data, grid, B, L, lam, ocfg, rmax_db, (1.0,))
    tried = []
    for gi in np.argsort(sc)[::-1]:
        if len(tried) >= ocfg.rescue_tries or not np.isfinite(sc[gi]):
            return
        f = float(grid[gi])
        if any(abs(np.log(f / t)) <= ocfg.rescue_rel for t in tried):
            continue
        tried.append(f)
        yield f


def _rescue(flight, est, scfg, rerun, ocfg: OrderConfig):
    """Where the lines found no comb over the whole range: the screen's likeliest rates
    (:func:`_rescue_rates`), each measured again with the search confined to it
    (``rescue_rel``); the first that finds a comb is judged as any estimate
    (:func:`resolve_order`). ``est`` where none does."""
    if len(est.time_s) == 0:
        return est
    for f in _rescue_rates(flight, est, scfg, ocfg):
        # a lone pair's likely comb (lone_p_min) holds over the whole range only: in a
        # window the screen chose, a chance pair of a smeared line is one
        narrow = replace(scfg, min_rev_s=f / (1 + ocfg.rescue_rel), max_rev_s=f * (1 + ocfg.rescue_rel), lone_p_min=0.0)
        new = rerun(narrow)
        if new.ok and new.valid.any():
            out = resolve_order(flight, new, narrow, rerun, ocfg)
            if "order" in out.info:
                out.info["order"]["rescued"] = (
                    f"the lines over {scfg.min_rev_s:g}-{scfg.max_rev_s:g} rev/s found "
                    f"no comb ({est.reason}); found within "
                    f"{narrow.min_rev_s:.1f}-{narrow.max_rev_s:.1f} rev/s"
                )
            return out
    return est


def _remeasure(flight, est, lines, ratio: float, scfg, rerun, ocfg: OrderConfig):
    """The estimate at ``ratio`` times the lines' rate: measured again with the search
    confined to the chosen rate's range (``rerun``, with the I/Q fit where ``scfg`` has
    it) where that finds it, else the lines' estimate scaled. Returns (estimate, how)."""
    v = lines.valid
    want = float(np.nanmedian(np.nanmedian(lines.speeds_rev_s[v], axis=1))) * ratio
    lo = float(np.nanmin(lines.common_rev_s[v])) * ratio / ocfg.rerun_margin
    hi = float(np.nanmax(lines.common_rev_s[v])) * ratio * ocfg.rerun_margin
    lo, hi = max(lo, 0.5 * ocfg.min_rev_s), min(hi, 1.5 * ocfg.max_rev_s)
    if rerun is not None and lo < hi:
        new = rerun(replace(scfg, min_rev_s=lo, max_rev_s=hi, lone_p_min=0.0), n_blades=int(est.n_blades))
        if new.ok and abs(np.log(float(np.nanmedian(new.common_rev_s[new.valid])) / want)) <= 0.03:
            return new, "measured again within %.1f-%.1f rev/s" % (lo, hi)
    out = replace(lines)
    out.speeds_rev_s, out.speeds_std_rev_s = lines.speeds_rev_s * ratio, lines.speeds_std_rev_s * ratio
    out.common_rev_s, out.common_std_rev_s = lines.common_rev_s * ratio, lines.common_std_rev_s * ratio
    return out, "the lines' estimate scaled (a re-measurement did not find the comb)"


def _method_difference(fit, lines) -> np.ndarray | None:
    """Per rotor rank: the I/Q fit's mean speed minus the lines' alone [rev/s], over the
    CPIs where both have every rank; None where they share fewer than two CPIs."""
    a, b = np.asarray(fit.speeds_rev_s), np.asarray(lines.speeds_rev_s)
    if a.shape != b.shape:
        return None
    both = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
    if both.sum() < 2:
        return None
    return np.mean(a[both], axis=0) - np.mean(b[both], axis=0)


def _within_spread(est, ocfg: OrderConfig):
    """A rotor far from the others sat on a line of another order or family (read at
    3/2 or 2/1 of its neighbours: an unequal blade's rotation-rate line taken for a
    blade-passing one, a scaled estimate's rotor on a third order's line): its speed is
    not measured; it goes to the median rotor, the change into sigma. The median is
    taken over the rotors of the CPI and its neighbours (+-2): in a CPI where half the
    rotors sat on another order's lines its own median is neither. Returns (estimate,
    rotors moved); the estimate itself where none is."""
    v = est.valid
    speeds, sds = np.array(est.speeds_rev_s, float), np.array(est.speeds_std_rev_s, float)
    common, common_sd = np.array(est.common_rev_s, float), np.array(est.common_std_rev_s, float)
    moved = 0
    for i in np.flatnonzero(v):
        near = v[max(0, i - 2) : i + 3]
        pool = speeds[max(0, i - 2) : i + 3][near]
        pool = pool[np.isfinite(pool)]
        if len(pool) == 0:
            continue
        med = float(np.median(pool))
        off = np.isfinite(speeds[i]) & (np.abs(speeds[i] / med - 1) > ocfg.rotor_spread_max)
        if off.any():
            moved += int(off.sum())
            sds[i, off] = np.hypot(sds[i, off], speeds[i, off] - med)
            speeds[i, off] = med
            mean = float(np.nanmean(speeds[i]))
            common_sd[i] = np.hypot(common_sd[i], common[i] - mean)
            common[i] = mean
    if not moved:
        return est, 0
    out = replace(est)
    out.speeds_rev_s, out.speeds_std_rev_s = speeds, sds
    out.common_rev_s, out.common_std_rev_s = common, common_sd
    return out, moved


def ambiguity_line(est) -> str | None:
    """One line naming an ambiguous order, e.g. ``ambiguous: 80.8 or 161.6 rev/s
    (likelihood ratio 1.3)``, with the odds against each alternative once weighed with the
    tip speed's prior where they differ; None where the order is not ambiguous."""
    o = (est.info or {}).get("order")
    if not o or not o.get("ambiguous"):
        return None
    alts = [(a, r) for a, r in zip(o["alternatives_rev_s"], o["relative_likelihood"])]
    speeds = " or ".join([f"{o['chosen_rev_s']:.1f}"] + [f"{a:.1f}" for a, _ in alts])
    ratios = ", ".join(f"{1 / r:.3g}" for _, r in alts)
    odds = o.get("posterior_odds")
    prior = (
        f"; with the tip speed's prior {', '.join(f'{1 / x:.3g}' if x > 0 else 'inf' for x in odds)}"
        if odds and list(odds) != list(o["relative_likelihood"])
        else ""
    )
    split = f"; {o['split']}" if o.get("split") else ""
    return (
        f"{est.flight_id}: rotor speed order ambiguous: {speeds} rev/s (likelihood ratio {ratios}{prior}{split}; "
        f"the store's rpm_std includes it)"
    )


def order_attrs(est) -> dict:
    """``motors_radar`` attributes of the order: the alternatives' mean speeds [rev/s]
    and their likelihood relative to the chosen one (empty lists where none)."""
    o = (est.info or {}).get("order")
    if not o:
        return {}
    return {
        "rotor_order": {
            k: o[k]
            for k in (
                "method",
                "chosen_rev_s",
                "lines_rev_s",
                "ratio_to_lines",
                "ambiguous",
                "remeasured",
                "order_rel_std",
            )
        },
        "rotor_order_alternatives_rev_s": list(o["alternatives_rev_s"]),
        "rotor_order_relative_likelihood": list(o["relative_likelihood"]),
    }
