"""Confidence intervals with the flight as the unit (a cluster bootstrap).

Images cut from one flight are correlated: they share its range, SNR, clutter and
drone. Treating them as independent makes every interval too narrow. Here a
bootstrap replicate draws *flights* with replacement (within each stratum, e.g. the
true class, so every replicate keeps the test set's class mix) and, where a
statistic is a mean over training seeds, also draws *seeds* with replacement. Paired
comparisons (training set A minus B, variant A minus B) reuse the same flight and
seed draws for both sides, so what they share cancels.

A difference is *resolved* when its 95 % interval excludes zero.

Every statistic here is a ratio of sums over flights (correct images over images,
for a subset of flights), so a replicate is two weighted sums: the draws are kept as
a matrix of flight multiplicities ``weights[b, f]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: default number of bootstrap replicates and interval level
N_BOOT = 2000
LEVEL = 0.95


@dataclass(frozen=True)
class FlightDraws:
    """Bootstrap draws of flights (and seeds).

    Attributes
    ----------
    flights : ndarray of str [n_flights]
        The flight ids, in the column order of ``weights``.
    weights : ndarray, float64 [n_boot, n_flights]
        How often each flight is drawn in each replicate.
    seeds : ndarray, int64 [n_boot, n_seeds] or None
        Positions (into the caller's seed list) drawn in each replicate.

    See Also
    --------
    draw_flights, ratio_replicates

    Examples
    --------
    >>> from microdoppler.stats import draw_flights
    >>> draws = draw_flights(["a", "b", "c"], n_boot=4, seed=0)
    >>> draws.n_boot, draws.weights.shape, draws.weights.sum(axis=1).tolist()
    (4, (4, 3), [3.0, 3.0, 3.0, 3.0])
    """

    flights: np.ndarray
    weights: np.ndarray
    seeds: np.ndarray | None = None

    @property
    def n_boot(self) -> int:
        return self.weights.shape[0]


def draw_flights(
    flight_ids, *, strata=None, n_seeds: int | None = None, n_boot: int = N_BOOT, seed: int = 0
) -> FlightDraws:
    """Draw flights with replacement within each stratum (and seeds, if ``n_seeds``).

    Parameters
    ----------
    flight_ids : sequence of str
        One entry per flight (unique).
    strata : sequence, optional
        The stratum of each flight (e.g. its true class); default one stratum.
    n_seeds : int, optional
        Also draw ``n_seeds`` seed positions with replacement per replicate.
    n_boot : int
        Replicates.
    seed : int
        Seed of the draws (same seed, same draws).

    Returns
    -------
    FlightDraws
        ``weights`` float64 [n_boot, n_flights]: how often each flight is drawn per
        replicate (each stratum keeps its size); ``seeds`` int64 [n_boot, n_seeds] or None.

    Raises
    ------
    ValueError
        When flight ids repeat, none are given, ``n_boot`` < 1 or ``strata`` has the
        wrong length.

    See Also
    --------
    ratio_replicates, interval

    Examples
    --------
    >>> from microdoppler.stats import draw_flights
    >>> draws = draw_flights(["a", "b", "c", "d"], strata=["bird", "bird", "drone", "drone"], n_boot=3, seed=1)
    >>> draws.weights[:, :2].sum(axis=1).tolist(), draws.weights[:, 2:].sum(axis=1).tolist()
    ([2.0, 2.0, 2.0], [2.0, 2.0, 2.0])
    """
    flights = np.asarray(list(flight_ids), dtype=str)
    if len(set(flights)) != len(flights):
        raise ValueError("flight_ids must be unique")
    if len(flights) == 0:
        raise ValueError("no flights to draw from")
    if n_boot < 1:
        raise ValueError(f"n_boot={n_boot} must be >= 1")
    strata = np.zeros(len(flights), int) if strata is None else np.asarray(list(strata))
    if len(strata) != len(flights):
        raise ValueError("strata must have one entry per flight")
    rng = np.random.default_rng(seed)
    w = np.zeros((n_boot, len(flights)))
    for s in np.unique(strata):
        idx = np.flatnonzero(strata == s)
        picks = rng.integers(0, len(idx), size=(n_boot, len(idx)))
        for j in range(len(idx)):  # multiplicities of each member of the stratum
            w[:, idx[j]] = (picks == j).sum(axis=1)
    seeds = rng.integers(0, n_seeds, size=(n_boot, n_seeds)) if n_seeds else None
    return FlightDraws(flights, w, seeds)


def interval(samples, level: float = LEVEL) -> tuple[float, float]:
    """Percentile interval of bootstrap ``samples`` (NaNs ignored).

    Parameters
    ----------
    samples : array-like, float [n_boot]
        Bootstrap replicates.
    level : float
        Coverage of the interval (default 0.95).

    Returns
    -------
    lo, hi : float
        The (1 - level) / 2 and (1 + level) / 2 quantiles; NaN, NaN when no sample is
        finite.

    See Also
    --------
    draw_flights, ratio_replicates

    Examples
    --------
    >>> import numpy as np
    >>> from microdoppler.stats import interval
    >>> [round(v, 6) for v in interval(np.arange(101.0))]
    [2.5, 97.5]
    >>> interval([np.nan])
    (nan, nan)
    """
    s = np.asarray(samples, float)
    s = s[np.isfinite(s)]
    if len(s) == 0:
        return float("nan"), float("nan")
    a = (1 - level) / 2
    lo, hi = np.quantile(s, [a, 1 - a])
    return float(lo), float(hi)


def resolved(lo: float, hi: float) -> bool:
    """True when the interval [lo, hi] excludes zero."""
    return bool(np.isfinite(lo) and np.isfinite(hi) and (lo > 0 or hi < 0))


def ratio_replicates(num, den, draws: FlightDraws) -> np.ndarray:
    """Replicates of a ratio of flight sums, averaged over the drawn seeds.

    Parameters
    ----------
    num : ndarray [n_seeds, n_flights] or [n_flights]
        Per seed and flight: the numerator (e.g. correct images in the subset).
    den : ndarray [n_flights]
        Per flight: the denominator (e.g. images in the subset).

    Returns
    -------
    ndarray, float64 [n_boot]
        sum_f w_bf num_sf / sum_f w_bf den_f, averaged over the seeds drawn in
        replicate b (or over all seeds when the draws hold none). A replicate
        whose subset is empty gives NaN.

    Raises
    ------
    ValueError
        When the draws hold more seeds than ``num`` has rows.

    See Also
    --------
    draw_flights, interval

    Examples
    --------
    Accuracy over flights (correct images over images), with its 95 % interval:

    >>> import numpy as np
    >>> from microdoppler.stats import draw_flights, interval, ratio_replicates
    >>> correct, images = np.array([9, 8, 10, 4]), np.array([10, 10, 10, 10])
    >>> draws = draw_flights(["a", "b", "c", "d"], n_boot=2000, seed=0)
    >>> reps = ratio_replicates(correct, images, draws)
    >>> reps.shape, round(float(correct.sum() / images.sum()), 3)
    ((2000,), 0.775)
    >>> lo, hi = interval(reps)
    >>> bool(lo < 0.775 < hi)
    True
    """
    num = np.atleast_2d(np.asarray(num, float))
    den = np.asarray(den, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        per_seed = (draws.weights @ num.T) / (draws.weights @ den)[:, None]  # [n_boot, n_seeds]
    if draws.seeds is None:
        return per_seed.mean(axis=1)
    if draws.seeds.max(initial=-1) >= per_seed.shape[1]:
        raise ValueError("draws hold more seeds than num has rows")
    return np.take_along_axis(per_seed, draws.seeds, axis=1).mean(axis=1)
