"""The flight bootstrap: coverage with correlated images, pairing, strata, seeds."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from microdoppler.stats.bootstrap import draw_flights, interval, ratio_replicates, resolved
from microdoppler.classifier.reports import table_v, metrics_table


def _clustered_test_set(rng, n_flights=30, images=12, mean=0.85, spread=3.0):
    """Per flight an accuracy p_f ~ Beta (flights differ), images Bernoulli(p_f):
    images of one flight are correlated through p_f. Returns correct counts, image
    counts and the population accuracy."""
    a, b = mean * spread, (1 - mean) * spread
    p = rng.beta(a, b, n_flights)
    n = np.full(n_flights, images)
    return rng.binomial(n, p).astype(float), n.astype(float), mean


@pytest.mark.slow
def test_flight_bootstrap_covers_and_image_bootstrap_does_not():
    """Over 150 simulated test sets, the flight bootstrap's 95 % interval holds the
    population accuracy about 95 % of the time; treating images as independent (each
    image its own "flight") gives intervals that are far too narrow."""
    rng = np.random.default_rng(11)
    hit_flight = hit_image = 0
    trials = 150
    for k in range(trials):
        correct, n, truth = _clustered_test_set(rng)
        d = draw_flights([f"f{i}" for i in range(len(n))], n_boot=300, seed=k)
        lo, hi = interval(ratio_replicates(correct, n, d))
        hit_flight += lo <= truth <= hi
        # image level: every image its own unit
        img = np.concatenate([np.r_[np.ones(int(c)), np.zeros(int(m - c))] for c, m in zip(correct, n)])
        di = draw_flights([f"i{i}" for i in range(len(img))], n_boot=300, seed=k)
        lo, hi = interval(ratio_replicates(img, np.ones(len(img)), di))
        hit_image += lo <= truth <= hi
    assert 0.89 <= hit_flight / trials <= 0.99, hit_flight
    assert hit_image / trials < 0.8, hit_image


def test_draws_keep_strata_sizes_and_are_seeded():
    ids = [f"f{i}" for i in range(10)]
    strata = ["bird"] * 4 + ["drone"] * 6
    d = draw_flights(ids, strata=strata, n_seeds=9, n_boot=500, seed=3)
    np.testing.assert_array_equal(d.weights[:, :4].sum(axis=1), 4)
    np.testing.assert_array_equal(d.weights[:, 4:].sum(axis=1), 6)
    assert d.seeds.shape == (500, 9) and d.seeds.min() >= 0 and d.seeds.max() <= 8
    again = draw_flights(ids, strata=strata, n_seeds=9, n_boot=500, seed=3)
    np.testing.assert_array_equal(d.weights, again.weights)
    np.testing.assert_array_equal(d.seeds, again.seeds)
    # every flight is drawn about once per replicate on average
    assert d.weights.mean(axis=0) == pytest.approx(np.ones(10), abs=0.12)


def test_paired_difference_resolves_a_real_gain_and_not_noise():
    rng = np.random.default_rng(5)
    n_f, n_s = 24, 9
    n = np.full(n_f, 10.0)
    base = rng.binomial(10, 0.8, (n_s, n_f)).astype(float)
    better = np.minimum(base + (rng.random((n_s, n_f)) < 0.5) * 1, 10)  # +5 points on average
    d = draw_flights([f"f{i}" for i in range(n_f)], n_seeds=n_s, n_boot=1000, seed=1)
    gain = ratio_replicates(better, n, d) - ratio_replicates(base, n, d)
    lo, hi = interval(gain)
    assert resolved(lo, hi) and lo > 0
    same = ratio_replicates(base, n, d) - ratio_replicates(base.copy(), n, d)
    assert interval(same) == (0.0, 0.0) and not resolved(*interval(same))


def test_table_v_intervals_widen_with_flight_correlation():
    """The same accuracies from 8 large flights vs 40 small ones: the interval of the
    clustered test set is wider (the flight is the unit)."""
    rng = np.random.default_rng(2)

    def preds(n_flights, per_flight):
        target = np.repeat(np.array(["bird", "drone"] * (n_flights // 2)), per_flight)
        fid = np.repeat([f"f{i}" for i in range(n_flights)], per_flight)
        model = np.where(target == "drone", "inspire2", "")
        out = {}
        p_f = rng.beta(8, 2, n_flights)
        for t in ("real", "sub_cpi"):
            for s in range(3):
                ok = rng.random(len(fid)) < np.repeat(p_f, per_flight)
                out[(t, s)] = pd.DataFrame(
                    {
                        "flight_id": fid,
                        "target": target,
                        "drone_model": model,
                        "predicted": np.where(ok, target, np.where(target == "bird", "drone", "bird")),
                        "radar_id": "1",
                    }
                )
        return out

    widths = []
    for nf, per in ((8, 40), (40, 8)):
        p = preds(nf, per)
        tv = table_v(metrics_table(p), p, n_boot=500).set_index("trainset")
        widths.append(tv.loc["real", "accuracy_ci95_high"] - tv.loc["real", "accuracy_ci95_low"])
        assert "accuracy_resolved" in tv.columns and "sub_cpi - real" in tv.index
    assert widths[0] > widths[1]


def test_bad_arguments():
    with pytest.raises(ValueError):
        draw_flights(["a", "a"])
    with pytest.raises(ValueError):
        draw_flights([])
    assert np.isnan(interval([np.nan, np.nan])[0])
