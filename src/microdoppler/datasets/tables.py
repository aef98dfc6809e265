"""Table III (composition of the sets) and Table IV (fitted simulation parameters).

SNR is :func:`microdoppler.spectra.snr.line_snr_db` of the body line (expected Doppler from
the track), per spectrogram timestep, as everywhere in the project.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..io.flightzarr import Flight
from ..io.outputs import atomic_file
from ..spectra.spectrogram import SpectrogramConfig
from ..spectra.snr import SNR_LINES
from ..spectra.snr import flight_body_snr_db, flight_line_snr_db  # noqa: F401 (the one SNR measure, re-exported)
from .split import CLASSES, SETS, n_images


def flight_snr_row(flight: Flight, *, spec_cfg: SpectrogramConfig, search_hz: float = 10.0) -> dict:
    """images, SNR mean and std over timesteps, the per-timestep SNRs of one flight and
    the line they are measured on (``snr_line``: ``body``, or ``rotor`` for a drone
    whose body sits in the clutter notch, :func:`microdoppler.spectra.snr.snr_line`)."""
    s, line = flight_line_snr_db(flight, spec_cfg=spec_cfg, search_hz=search_hz)
    f = s[np.isfinite(s)]
    return dict(
        images=n_images(len(flight.iq), spec_cfg),
        snr_mean_db=float(np.mean(f)) if f.size else np.nan,
        snr_std_db=float(np.std(f)) if f.size else np.nan,
        snr_line=line,
        snr_db=f,
    )


def table_iii(split: pd.DataFrame, snr: dict[str, np.ndarray], snr_line: dict[str, str] | None = None) -> pd.DataFrame:
    """Composition of the sets (paper Table III).

    Parameters
    ----------
    split : DataFrame
        flight_id, set, class, radar_id, images.
    snr : dict flight_id -> ndarray
        Per-timestep SNR [dB] of each flight (its body line's, or its rotor lines').
    snr_line : dict flight_id -> str, optional
        The line each flight's SNR is measured on (``body`` or ``rotor``,
        :func:`flight_snr_row`). When some flight's is ``rotor``, a column ``snr_line``
        says which lines each row's SNR pools (``body``, ``rotor`` or ``body+rotor``);
        without any, the table has no such column (the body line throughout).

    Returns
    -------
    DataFrame, one row per set and class plus a row ``all`` per set: flights, images,
    pct_radar_<id> (share of the set's images from that radar [%]), snr_mean_db,
    snr_std_db (over the timesteps of all its flights), flight_snr_std_mean_db,
    flight_snr_std_std_db (mean and spread over flights of each flight's SNR std).
    """
    radars = sorted(split.radar_id.astype(str).unique())
    snr_line = snr_line or {}
    with_line = any(ln != "body" for ln in snr_line.values())
    rows = []
    for s in SETS:
        in_set = split[split.set == s]
        set_images = max(int(in_set.images.sum()), 1)
        classes = [c for c in CLASSES if c in set(split["class"])] + sorted(set(split["class"]) - set(CLASSES))
        for cls in classes + ["all"]:
            part = in_set if cls == "all" else in_set[in_set["class"] == cls]
            vals = [snr.get(f, np.empty(0)) for f in part.flight_id]
            pooled = np.concatenate(vals) if vals else np.empty(0)
            stds = np.array([np.std(v) for v in vals if len(v) > 1])
            row = dict(set=s, **{"class": cls}, flights=len(part), images=int(part.images.sum()))
            for r in radars:
                row[f"pct_radar_{r}"] = round(100.0 * part.images[part.radar_id.astype(str) == r].sum() / set_images, 1)
            row.update(
                snr_mean_db=float(np.mean(pooled)) if pooled.size else np.nan,
                snr_std_db=float(np.std(pooled)) if pooled.size else np.nan,
                flight_snr_std_mean_db=float(np.mean(stds)) if stds.size else np.nan,
                flight_snr_std_std_db=float(np.std(stds)) if stds.size else np.nan,
            )
            if with_line:
                used = [ln for ln in SNR_LINES if ln in {snr_line.get(f, "body") for f in part.flight_id}]
                row["snr_line"] = "+".join(used)
            rows.append(row)
    return pd.DataFrame(rows)


TABLE_IV_COLUMNS = [
    "flight_id",
    "variant",
    "drone_model",
    "radar_id",
    "status",
    "window_pulses",
    "fixed_rev_s",
    "alpha_s",
    "s_body",
    "s_blade",
    "n_pairs_measured",
    "n_pairs_twin",
    "body_snr_measured_db",
    "body_snr_twin_db",
    "body_error_db",
    "sideband1_snr_measured_db",
    "sideband1_snr_twin_db",
    "sideband1_error_db",
    "fit_seconds",
]


def aggregate_table_iv(paths) -> pd.DataFrame:
    """Paper-style Table IV from the per-variant tables: min/max of S_body, S_blade and
    alpha per variant, drone model and radar, with flight counts and the worst errors."""
    df = pd.concat([pd.read_csv(p, dtype={"flight_id": str, "radar_id": str}) for p in paths], ignore_index=True)
    fit = df[df.status.isin(["ok", "missed"])]
    if fit.empty:
        return pd.DataFrame(columns=["variant", "drone_model", "radar_id", "flights", "missed"])
    g = fit.groupby(["variant", "drone_model", "radar_id"])
    out = g.agg(
        flights=("flight_id", "size"),
        missed=("status", lambda s: int((s == "missed").sum())),
        s_body_min=("s_body", "min"),
        s_body_max=("s_body", "max"),
        s_blade_min=("s_blade", "min"),
        s_blade_max=("s_blade", "max"),
        alpha_s_min=("alpha_s", "min"),
        alpha_s_max=("alpha_s", "max"),
        max_abs_body_error_db=("body_error_db", lambda s: float(np.max(np.abs(s)))),
        max_abs_sideband1_error_db=(
            "sideband1_error_db",
            lambda s: float(np.nanmax(np.abs(s))) if s.notna().any() else np.nan,
        ),
    )
    skipped = df[~df.status.isin(["ok", "missed"])].groupby("variant").size().rename("skipped")
    out = out.reset_index().merge(skipped, on="variant", how="left").fillna({"skipped": 0})
    return out


def write_csv(df: pd.DataFrame, path) -> Path:
    """Write a CSV atomically (temporary file, then rename)."""
    with atomic_file(path) as tmp:
        df.to_csv(tmp, index=False)
    return Path(path)
