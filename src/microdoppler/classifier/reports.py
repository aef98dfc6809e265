"""Reports over seeds: metrics.csv, mean confusion matrices (Fig. 6), Table V, Fig. 12."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..stats.bootstrap import N_BOOT, draw_flights, interval, ratio_replicates, resolved
from ..io.outputs import atomic_file
from .data import CLASSES, LARGE_DRONES, SMALL_DRONES
from .metrics import confusion_matrix, seed_metrics

#: Table V of the paper (mean ± std over 9 seeds, %): accuracy, drone recall,
#: bird recall, large-drone accuracy, small-drone accuracy.
PAPER_TABLE_V = {
    "real": ((89.7, 0.5), (88.0, 1.2), (90.5, 1.3), (94.0, 1.1), (73.3, 2.2)),
    "sub_cpi": ((86.6, 0.5), (80.1, 0.8), (93.0, 0.9), (85.4, 0.7), (67.3, 1.4)),
    "per_cpi": ((85.9, 0.4), (77.8, 1.0), (93.9, 0.5), (83.0, 1.0), (65.4, 2.1)),
    "single_motor": ((86.1, 0.1), (79.0, 1.0), (93.3, 0.8), (84.2, 1.0), (66.6, 1.8)),
    "fixed_speeds": ((84.4, 0.7), (74.3, 2.0), (94.5, 1.0), (78.3, 2.6), (64.8, 2.2)),
}
TABLE_V_METRICS = ("accuracy", "drone_recall", "bird_recall", "large_drone_accuracy", "small_drone_accuracy")
#: Fig. 6 of the paper: mean confusion matrix of the real baseline (rows true bird, drone).
PAPER_FIG6 = np.array([[1661, 157], [219, 1599]])
ORDER = ("real", "sub_cpi", "per_cpi", "single_motor", "fixed_speeds", "extended")
#: paired differences reported besides ``<set> - real``: the paper's adjacent orderings
#: (sub-CPI > per-CPI ~ single-motor > fixed-speeds) and the extension's gain
PAIRS = (("sub_cpi", "per_cpi"), ("per_cpi", "single_motor"), ("single_motor", "fixed_speeds"), ("extended", "sub_cpi"))


def _order(trainsets) -> list[str]:
    trainsets = list(dict.fromkeys(trainsets))
    return [t for t in ORDER if t in trainsets] + sorted(t for t in trainsets if t not in ORDER)


def _write_csv(df: pd.DataFrame, path) -> None:
    with atomic_file(path) as tmp:
        df.to_csv(tmp, index=False, float_format="%.6g")


def _save_fig(fig, path) -> None:
    with atomic_file(path) as tmp:
        fig.savefig(tmp, dpi=120, bbox_inches="tight")


def metrics_table(predictions: dict) -> pd.DataFrame:
    """Per-run figures of merit.

    Parameters
    ----------
    predictions : dict (trainset, seed) -> DataFrame
        Prediction tables of ``evaluate_classifier``.

    Returns
    -------
    DataFrame: trainset, seed, accuracy, drone/bird recall and precision,
    large/small-drone accuracy, n_test, accuracy_radar_<id>; fractions in [0, 1].
    """
    rows = [dict(trainset=t, seed=int(s), **seed_metrics(p)) for (t, s), p in predictions.items()]
    df = pd.DataFrame(rows)
    df["_o"] = df["trainset"].map({t: i for i, t in enumerate(_order(df["trainset"]))})
    return df.sort_values(["_o", "seed"]).drop(columns="_o").reset_index(drop=True)


def mean_confusion(predictions: dict, trainset: str) -> np.ndarray:
    """Mean over seeds of the confusion counts (rows true, columns predicted), float [2, 2]."""
    cms = [confusion_matrix(p["target"], p["predicted"]) for (t, _), p in predictions.items() if t == trainset]
    return np.mean(cms, axis=0)


def confusion_frame(cm: np.ndarray) -> pd.DataFrame:
    """Confusion matrix as a table: true, predicted_bird, predicted_drone."""
    return pd.DataFrame({"true": list(CLASSES), **{f"predicted_{c}": cm[:, j] for j, c in enumerate(CLASSES)}})


def flight_counts(predictions: dict):
    """Per flight of the test set: its class and model, image count, and per (trainset,
    seed) the number of correctly classified images.

    Returns
    -------
    flights : DataFrame indexed by flight_id (target, drone_model, n_images)
    correct : dict (trainset, seed) -> ndarray [n_flights]
    """
    first = next(iter(predictions.values()))
    flights = first.groupby("flight_id", sort=True).agg(
        target=("target", "first"), drone_model=("drone_model", "first"), n_images=("target", "size")
    )
    correct = {}
    for key, p in predictions.items():
        n = p.groupby("flight_id").size().reindex(flights.index)
        if n.isna().any() or not np.array_equal(n.to_numpy(), flights["n_images"].to_numpy()):
            raise ValueError(f"predictions {key} are not on the same test images as {next(iter(predictions))}")
        ok = (p["target"] == p["predicted"]).groupby(p["flight_id"]).sum().reindex(flights.index)
        correct[key] = ok.to_numpy(float)
    return flights, correct


def _subsets(flights: pd.DataFrame) -> dict:
    """Flights each Table V metric is computed over (every metric is correct/images)."""
    drone = (flights["target"] == "drone").to_numpy()
    model = flights["drone_model"].astype(str)
    return {
        "accuracy": np.ones(len(flights), bool),
        "drone_recall": drone,
        "bird_recall": (flights["target"] == "bird").to_numpy(),
        "large_drone_accuracy": drone & model.isin(LARGE_DRONES).to_numpy(),
        "small_drone_accuracy": drone & model.isin(SMALL_DRONES).to_numpy(),
    }


def bootstrap_table_v(predictions: dict, *, n_boot: int = N_BOOT, seed: int = 0) -> dict:
    """Replicates (in %) of every Table V metric per training set, from one shared set of
    draws of test flights (within class) and of seeds: {trainset: {metric: [n_boot]}}.

    The same draws serve every training set, so paired differences are replicate-wise
    differences. Seeds are matched by number (the seeds common to all training sets).
    """
    flights, correct = flight_counts(predictions)
    trainsets = _order({t for t, _ in predictions})
    seeds = sorted(set.intersection(*({s for t2, s in predictions if t2 == t} for t in trainsets)))
    draws = draw_flights(flights.index, strata=flights["target"], n_seeds=len(seeds), n_boot=n_boot, seed=seed)
    out = {}
    for t in trainsets:
        num = np.stack([correct[(t, s)] for s in seeds])
        out[t] = {
            m: 100 * ratio_replicates(num * mask, flights["n_images"].to_numpy(float) * mask, draws)
            for m, mask in _subsets(flights).items()
        }
    return out


def table_v(
    metrics: pd.DataFrame, predictions: dict | None = None, *, n_boot: int = N_BOOT, seed: int = 0
) -> pd.DataFrame:
    """Table V: mean ± std over seeds (in %) per training set, beside the paper's values,
    with 95 % intervals from a bootstrap over test flights and seeds.

    Columns per metric m: ``m_mean``, ``m_std`` (sample std over seeds, ddof=1), ``m``
    (formatted "mean ± std"), ``paper_m`` (the paper's "mean ± std" or empty) and, with
    ``predictions``, ``m_ci95_low``/``m_ci95_high`` (:mod:`microdoppler.stats.bootstrap`:
    flights drawn within class, seeds drawn, 95 % percentile interval); plus bird/drone
    precision (not in the paper) and n_seeds.

    Difference rows ``A - B`` (paired: same seeds, same bootstrap draws; positive = A
    better) for every training set against ``real``, for the paper's adjacent orderings
    and for ``extended - sub_cpi`` where both are present: the mean ± std over seeds of
    the per-seed difference, its interval, and ``m_resolved`` (the interval excludes 0).
    """
    rows = []
    extra = ("drone_precision", "bird_precision")
    boot = bootstrap_table_v(predictions, n_boot=n_boot, seed=seed) if predictions else {}
    order = _order(metrics["trainset"])
    for t in order:
        g = metrics[metrics["trainset"] == t]
        row = {"trainset": t, "n_seeds": len(g)}
        for i, m in enumerate(TABLE_V_METRICS + extra):
            mean, std = 100 * g[m].mean(), 100 * g[m].std(ddof=1) if len(g) > 1 else float("nan")
            row[f"{m}_mean"], row[f"{m}_std"], row[m] = mean, std, f"{mean:.1f} ± {std:.1f}"
            if m in TABLE_V_METRICS:
                paper = PAPER_TABLE_V.get(t)
                row[f"paper_{m}"] = f"{paper[i][0]:.1f} ± {paper[i][1]:.1f}" if paper else ""
                if boot:
                    row[f"{m}_ci95_low"], row[f"{m}_ci95_high"] = interval(boot[t][m])
        rows.append(row)
    pairs = [(t, "real") for t in order if t != "real" and "real" in order]
    pairs += [p for p in PAIRS if p[0] in order and p[1] in order and p not in pairs]
    for a_set, b_set in pairs:
        a = metrics[metrics["trainset"] == a_set].set_index("seed")
        b = metrics[metrics["trainset"] == b_set].set_index("seed")
        seeds = a.index.intersection(b.index)
        row = {"trainset": f"{a_set} - {b_set}", "n_seeds": len(seeds)}
        for m in TABLE_V_METRICS:
            d = 100 * (a.loc[seeds, m] - b.loc[seeds, m])
            mean, std = d.mean(), d.std(ddof=1) if len(d) > 1 else float("nan")
            row[f"{m}_mean"], row[f"{m}_std"], row[m] = mean, std, f"{mean:+.1f} ± {std:.1f}"
            if boot:
                lo, hi = interval(boot[a_set][m] - boot[b_set][m])
                row[f"{m}_ci95_low"], row[f"{m}_ci95_high"], row[f"{m}_resolved"] = lo, hi, resolved(lo, hi)
        rows.append(row)
    return pd.DataFrame(rows)


def plot_confusion(cm: np.ndarray, title: str, path) -> None:
    """Fig. 6-style mean confusion matrix (counts and row percentages)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(3.6, 3.2))
    ax.imshow(cm / np.maximum(cm.sum(1, keepdims=True), 1e-12), cmap="Blues", vmin=0, vmax=1)
    for i in range(2):
        for j in range(2):
            pct = 100 * cm[i, j] / max(cm[i].sum(), 1e-12)
            ax.text(
                j, i, f"{cm[i, j]:.1f}\n({pct:.1f} %)", ha="center", va="center", color="white" if pct > 60 else "black"
            )
    ax.set_xticks([0, 1], [c.capitalize() for c in CLASSES])
    ax.set_yticks([0, 1], [c.capitalize() for c in CLASSES])
    ax.set_xlabel("Predicted class")
    ax.set_ylabel("True class")
    ax.set_title(title, fontsize=9)
    _save_fig(fig, path)
    plt.close(fig)


def plot_boxplot(metrics: pd.DataFrame, path) -> None:
    """Fig. 12: accuracy (black), bird recall (blue), drone recall (red) per training set."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    order = _order(metrics["trainset"])
    series = (
        ("accuracy", "black", "Accuracy"),
        ("bird_recall", "tab:blue", "Bird recall"),
        ("drone_recall", "tab:red", "Drone recall"),
    )
    fig, ax = plt.subplots(figsize=(1.4 * len(order) + 2, 3.8))
    for k, (m, colour, label) in enumerate(series):
        data = [100 * metrics.loc[metrics["trainset"] == t, m].dropna().to_numpy() for t in order]
        pos = np.arange(len(order)) + (k - 1) * 0.27
        bp = ax.boxplot(
            data,
            positions=pos,
            widths=0.22,
            whis=1.5,
            patch_artist=False,
            flierprops=dict(marker="+", markeredgecolor="red"),
            medianprops=dict(color="red"),
        )
        for part in ("boxes", "whiskers", "caps"):
            for line in bp[part]:
                line.set_color(colour)
        ax.plot([], [], color=colour, label=label)
    ax.set_xticks(np.arange(len(order)), order)
    ax.set_ylabel("Test performance [%]")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    _save_fig(fig, path)
    plt.close(fig)


def write_reports(predictions: dict, out_dir, *, confusion_trainsets=None) -> dict:
    """Write metrics.csv, table_v.csv, confusion_{trainset}.csv/.png and fig12_boxplot.png.

    Returns the written paths by name.
    """
    out_dir = Path(out_dir)
    metrics = metrics_table(predictions)
    paths = {
        "metrics": out_dir / "metrics.csv",
        "table_v": out_dir / "table_v.csv",
        "fig12": out_dir / "fig12_boxplot.png",
    }
    _write_csv(metrics, paths["metrics"])
    _write_csv(table_v(metrics, predictions), paths["table_v"])
    for t in confusion_trainsets or _order(metrics["trainset"]):
        cm = mean_confusion(predictions, t)
        n = int((metrics["trainset"] == t).sum())
        _write_csv(confusion_frame(cm), out_dir / f"confusion_{t}.csv")
        plot_confusion(cm, f"{t}: mean of {n} seeds", out_dir / f"confusion_{t}.png")
        paths[f"confusion_{t}"] = out_dir / f"confusion_{t}.csv"
    plot_boxplot(metrics, paths["fig12"])
    return paths
