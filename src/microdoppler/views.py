"""Looking at a flight-zarr/1 store: its spectrogram in physical units, the rotor speeds
it holds and a table of them (``microdoppler show``).

:func:`rotor_table` reads the rotor speeds exactly as the store holds them
(``motors/time_s``, ``motors/rpm`` and, for speeds estimated from the radar, the
``motors_radar`` attribute: ``method``, ``rpm_std`` and the order's alternatives);
:func:`plot_store` draws one figure per store: the spectrogram over the whole PRF, the
same over the span the pipeline's images keep, and the rotor speeds per rotor over
time with their ±2 sigma band and any alternative order. The spectrograms are those of
:func:`microdoppler.spectra.spectrogram.spectrogram`.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from .errors import InputError
from .io.flightzarr import Flight
from .spectra.spectrogram import C_MPS, Spectrogram, SpectrogramSettings, blade_tip_doppler_hz, spectrogram

#: columns of the rotor-speed table (:func:`rotor_table`, ``rotor_speeds.csv``)
TABLE_COLUMNS = (
    "flight_id",
    "rotor",
    "source",
    "method",
    "n_rows",
    "mean_rev_s",
    "sigma_rev_s",
    "mean_sigma_rev_s",
    "scatter_rev_s",
    "ambiguous",
    "alternatives_rev_s",
    "alternatives_likelihood",
)
#: what each column holds (printed in the docs and the command's help)
COLUMN_DOC = {
    "flight_id": "the store's flight",
    "rotor": "1-based column of motors/rpm: a rotor rank in ascending speed for speeds from the radar "
    "(motors_source radar), a physical motor for a log",
    "source": "motors_source: radar (estimated from the HERM lines) or log",
    "method": "motors_radar.method for speeds from the radar, 'motor log' otherwise",
    "n_rows": "rows of motors/rpm",
    "mean_rev_s": "mean of the column over its rows [rev/s] (motors/rpm / 60)",
    "sigma_rev_s": "root mean square of the column's motors_radar.rpm_std / 60 over its rows [rev/s]: the one-sigma "
    "uncertainty the store gives a row (empty for a log)",
    "mean_sigma_rev_s": "motors_radar.mean_rpm_std / 60 [rev/s]: the one-sigma uncertainty of the column's mean "
    "over the recording (the CPIs' sigma or their scatter about the local trend, with their overlap; the mean minus "
    "the median; and the difference between the lines' and the I/Q fit's means; "
    "microdoppler.rotors.speed.recording_means); empty for a log",
    "scatter_rev_s": "standard deviation of the column's rows [rev/s] (the speed's change over the flight and "
    "the row-to-row noise)",
    "ambiguous": "motors_radar.rotor_order.ambiguous: another order of the HERM comb explains the lines alike "
    "(empty for a log)",
    "alternatives_rev_s": "the alternative orders' speeds for this rotor [rev/s]: mean_rev_s x "
    "rotor_order_alternatives_rev_s / rotor_order.chosen_rev_s, separated by ';'",
    "alternatives_likelihood": "each alternative's likelihood relative to the chosen order "
    "(motors_radar.rotor_order_relative_likelihood), separated by ';'",
}


def rotor_speeds(flight: Flight) -> dict | None:
    """The store's rotor speeds as it holds them, or None without ``motors/*``.

    Returns
    -------
    dict
        ``time_s`` [n_log], ``rev_s`` [n_log, n_motors] (motors/rpm / 60), ``std_rev_s``
        [n_log, n_motors] or None (``motors_radar.rpm_std`` / 60), ``mean_std_rev_s``
        (per column, ``motors_radar.mean_rpm_std`` / 60) or None, ``source`` ("radar"
        or "log"), ``method``, ``ambiguous`` (bool or None), ``ratios`` (alternative
        order over the chosen one, one per alternative), ``alternatives_rev_s`` and
        ``chosen_rev_s`` (the store's), and ``likelihood``.
    """
    if not flight.has_motor_log:
        return None
    rev = np.asarray(flight.motors_rpm, np.float64) / 60.0
    source = str(flight.attrs.get("motors_source", "log"))
    out = {
        "time_s": np.asarray(flight.motors_time_s, np.float64),
        "rev_s": rev,
        "std_rev_s": None,
        "mean_std_rev_s": None,
        "source": source,
        "method": "motor log",
        "ambiguous": None,
        "ratios": [],
        "likelihood": [],
        "alternatives_rev_s": [],
    }
    radar = flight.attrs.get("motors_radar") if source == "radar" else None
    if isinstance(radar, dict):
        out["method"] = str(radar.get("method", ""))
        std = radar.get("rpm_std")
        if std is not None:
            s = np.asarray(std, np.float64) / 60.0
            if s.shape != rev.shape:
                raise InputError(
                    flight.flight_id,
                    "motors_radar.rpm_std",
                    f"has shape {s.shape}",
                    f"the shape of motors/rpm, {rev.shape}",
                )
            out["std_rev_s"] = s
        mean_std = radar.get("mean_rpm_std")
        if mean_std is not None:
            if len(mean_std) != rev.shape[1]:
                raise InputError(
                    flight.flight_id,
                    "motors_radar.mean_rpm_std",
                    f"has {len(mean_std)} values",
                    f"one per column of motors/rpm, {rev.shape[1]}",
                )
            out["mean_std_rev_s"] = [None if v is None else float(v) / 60.0 for v in mean_std]
        order = radar.get("rotor_order") or {}
        out["ambiguous"] = bool(order["ambiguous"]) if "ambiguous" in order else None
        alts = list(radar.get("rotor_order_alternatives_rev_s") or [])
        chosen = order.get("chosen_rev_s")
        if alts and chosen:
            out["alternatives_rev_s"] = [float(a) for a in alts]
            out["chosen_rev_s"] = float(chosen)
            out["ratios"] = [float(a) / float(chosen) for a in alts]
            out["likelihood"] = [float(x) for x in radar.get("rotor_order_relative_likelihood") or []]
    return out


def rotor_table(flight: Flight) -> list[dict]:
    """One row per rotor (column of ``motors/rpm``) with :data:`TABLE_COLUMNS`; empty
    without rotor speeds. Numbers are floats (NaN-free), empties are ``None``."""
    sp = rotor_speeds(flight)
    if sp is None:
        return []
    rows = []
    for j in range(sp["rev_s"].shape[1]):
        col = sp["rev_s"][:, j]
        mean = float(np.mean(col))
        sigma = None if sp["std_rev_s"] is None else float(np.sqrt(np.mean(sp["std_rev_s"][:, j] ** 2)))
        rows.append(
            {
                "flight_id": flight.flight_id,
                "rotor": j + 1,
                "source": sp["source"],
                "method": sp["method"],
                "n_rows": int(len(col)),
                "mean_rev_s": mean,
                "sigma_rev_s": sigma,
                "mean_sigma_rev_s": None if sp["mean_std_rev_s"] is None else sp["mean_std_rev_s"][j],
                "scatter_rev_s": float(np.std(col, ddof=1)) if len(col) > 1 else 0.0,
                "ambiguous": sp["ambiguous"],
                "alternatives_rev_s": [mean * a / sp["chosen_rev_s"] for a in sp["alternatives_rev_s"]],
                "alternatives_likelihood": list(sp["likelihood"]),
            }
        )
    return rows


def _cell(v, digits: int | None = None) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.{digits}f}" if digits is not None else repr(v)
    if isinstance(v, list):
        return ";".join(_cell(x, digits) for x in v)
    return str(v)


def table_csv(rows: list[dict]) -> str:
    """The rows as CSV text (full precision: ``repr`` of each float)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(TABLE_COLUMNS)
    for r in rows:
        w.writerow([_cell(r[c]) for c in TABLE_COLUMNS])
    return buf.getvalue()


def table_text(rows: list[dict]) -> str:
    """The rows as an aligned text table (speeds to 0.01 rev/s)."""
    head = (
        "flight",
        "rotor",
        "mean rev/s",
        "sigma",
        "mean's sigma",
        "scatter",
        "method",
        "ambiguous",
        "alternatives rev/s",
    )
    body = [
        (
            r["flight_id"],
            str(r["rotor"]),
            _cell(r["mean_rev_s"], 2),
            _cell(r["sigma_rev_s"], 2),
            _cell(r["mean_sigma_rev_s"], 2),
            _cell(r["scatter_rev_s"], 2),
            r["method"],
            _cell(r["ambiguous"]),
            _cell(r["alternatives_rev_s"], 2),
        )
        for r in rows
    ]
    widths = [max(len(x) for x in col) for col in zip(head, *body)]
    return "\n".join("  ".join(x.ljust(w) for x, w in zip(line, widths)).rstrip() for line in (head, *body))


def spectrograms(flight: Flight, settings: SpectrogramSettings | None = None) -> tuple:
    """``(whole, image, cfg)``: the flight's spectrogram over the whole PRF and over the
    span the pipeline's images keep, both at the pipeline's CPI (``settings``, default
    the paper's), and the resolved :class:`~microdoppler.spectra.spectrogram.SpectrogramConfig`.

    Raises
    ------
    InputError
        When the recording is shorter than one CPI.
    """
    settings = settings or SpectrogramSettings()
    cfg = settings.resolve(flight.prf_hz, flight.carrier_hz, blade_length_m=flight.attrs.get("blade_length_m"))
    n = len(flight.iq)
    if n < cfg.n_fft:
        raise InputError(
            flight.flight_id,
            "iq",
            f"holds {n} pulses ({n / flight.prf_hz:.3g} s)",
            f"at least one CPI, {cfg.n_fft} pulses ({cfg.n_fft / flight.prf_hz:.3g} s)",
        )
    whole = spectrogram(flight.iq, flight.prf_hz, replace(cfg, n_bins=0))
    image = whole if cfg.n_bins in (0, cfg.n_fft) else spectrogram(flight.iq, flight.prf_hz, cfg)
    return whole, image, cfg


def for_display(spec: Spectrogram, max_rows: int = 600) -> tuple[Spectrogram, int]:
    """``(spec, k)``: ``spec`` with every ``k`` adjacent Doppler bins replaced by their
    largest power so that at most ``max_rows`` rows remain (k = 1: unchanged). A figure
    of a few hundred pixel rows shows every line this way; nearest-pixel sampling of
    thousands of bins would drop most of them."""
    n = spec.power_db.shape[1]
    k = max(1, math.ceil(n / max_rows))
    if k == 1:
        return spec, 1
    m = n // k
    p = spec.power_db[:, : m * k].reshape(len(spec.time_s), m, k).max(axis=2)
    f = spec.doppler_hz[: m * k].reshape(m, k).mean(axis=1)
    return Spectrogram(p, spec.time_s, f), k


def _range_db(spec: Spectrogram, dynamic_range_db: float) -> float:
    """The colour range: from 3 dB under the median (the noise floor) to the peak, at
    most ``dynamic_range_db``."""
    p = np.asarray(spec.power_db, np.float64)
    return float(min(dynamic_range_db, max(10.0, p.max() - np.median(p) + 3.0)))


def _velocity_axis(ax, carrier_hz: float) -> None:
    """A right-hand axis in radial velocity [m/s] (v = f lambda / 2)."""
    k = C_MPS / carrier_hz / 2.0
    sec = ax.secondary_yaxis("right", functions=(lambda f: f * k, lambda v: v / k))
    sec.set_ylabel("radial velocity [m/s]")


def plot_store(
    flight: Flight, out_png, *, settings: SpectrogramSettings | None = None, dynamic_range_db: float = 60.0
) -> Path:
    """Write the figure of one store to ``out_png`` and return its path.

    Panels: (a) the spectrogram over the whole PRF (±PRF / 2) with the blade tips'
    largest Doppler at the stored mean rotor speeds (dashed, where the store holds
    speeds); (b) the same over the span the pipeline's images keep; (c) where the store
    holds rotor speeds, each rotor's speed over time [rev/s] with its ±2 sigma band
    (speeds from the radar) and any alternative order (dotted). Spectrograms of more
    bins than a figure has pixel rows are shown by their largest power per row
    (:func:`for_display`); the colours span from the noise floor to the peak.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .figures import _save, plot_spectrogram

    whole, image, cfg = spectrograms(flight, settings)
    sp = rotor_speeds(flight)
    a = flight.attrs
    n_panels = 3 if sp is not None else 2
    fig, axes = plt.subplots(n_panels, 1, figsize=(12, 4.2 * n_panels), constrained_layout=True, squeeze=False)
    axes = axes[:, 0]
    cpi = f"CPI {cfg.n_fft} pulses = {cfg.n_fft / flight.prf_hz:.3g} s"
    span = cfg.doppler_span_hz(flight.prf_hz)
    titles = (
        f"(a) whole PRF: ±{flight.prf_hz / 2:.0f} Hz ({cpi})",
        f"(b) the images' span: {span:.0f} Hz = {span * C_MPS / flight.carrier_hz / 2:.1f} m/s "
        f"({cfg.n_bins or cfg.n_fft} bins)",
    )
    for ax, spec, title in zip(axes[:2], (whole, image), titles):
        shown, k = for_display(spec)
        im = plot_spectrogram(
            ax,
            shown,
            dynamic_range_db=_range_db(spec, dynamic_range_db),
            title=title + (f", max of {k} bins per row" if k > 1 else ""),
        )
        fig.colorbar(im, ax=ax, label="power [dB]", pad=0.01)
        _velocity_axis(ax, flight.carrier_hz)
        ax.set_ylim(spec.doppler_hz[0], spec.doppler_hz[-1])
    if sp is not None and a.get("blade_length_m"):
        tips = [
            blade_tip_doppler_hz(float(np.mean(sp["rev_s"][:, j])), float(a["blade_length_m"]), flight.carrier_hz)
            for j in range(sp["rev_s"].shape[1])
        ]
        top = max(tips)
        box = {"facecolor": "w", "alpha": 0.8, "lw": 0}
        if top < flight.prf_hz / 2:
            for s in (1, -1):
                axes[0].axhline(s * top, color="w", ls="--", lw=1.0)
            axes[0].text(
                0.01,
                0.02,
                f"dashed: the blade tips' Doppler at the mean speed, ±{top:.0f} Hz",
                transform=axes[0].transAxes,
                fontsize=9,
                bbox=box,
            )
        else:
            axes[0].text(
                0.01,
                0.02,
                f"the blade tips' Doppler at the mean speed, ±{top:.0f} Hz, folds past ±PRF/2",
                transform=axes[0].transAxes,
                fontsize=9,
                bbox=box,
            )
    if sp is not None:
        ax = axes[2]
        t, rev, std = sp["time_s"], sp["rev_s"], sp["std_rev_s"]
        colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
        for j in range(rev.shape[1]):
            c = colours[j % len(colours)]
            what = "rank" if sp["source"] == "radar" else "motor"
            ax.plot(t, rev[:, j], "-", color=c, lw=1.2, label=f"{what} {j + 1}: {np.mean(rev[:, j]):.1f} rev/s")
            if std is not None:
                ax.fill_between(t, rev[:, j] - 2 * std[:, j], rev[:, j] + 2 * std[:, j], color=c, alpha=0.2, lw=0)
            for r in sp["ratios"]:
                ax.plot(t, rev[:, j] * r, ":", color=c, lw=1.0)
        if sp["ratios"]:
            ax.plot([], [], "k:", label="alternative order ×" + ", ×".join(f"{r:.3g}" for r in sp["ratios"]))
        band = " with ±2σ bands" if std is not None else ""
        amb = "; order ambiguous" if sp["ambiguous"] else ""
        ax.set_title(f"(c) rotor speeds ({sp['source']}: {sp['method']}){band}{amb}")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("rotor speed [rev/s]")
        ax.set_xlim(axes[0].get_xlim())
        ax.legend(fontsize=8, ncol=2, loc="best")
        ax.grid(alpha=0.3)
    desc = (
        f"{a.get('drone_model', '')} {a.get('n_motors', '')}x{a.get('n_blades', '')} blades, "
        f"L {a.get('blade_length_m')} m, "
        if a.get("target") == "drone"
        else f"{a.get('target')}, "
    )
    fig.suptitle(
        f"{flight.flight_id}: {desc}{flight.carrier_hz / 1e9:.4g} GHz, PRF {flight.prf_hz:g} Hz, "
        f"{flight.duration_s:.2f} s"
    )
    return _save(fig, out_png)
