"""Step 4 of the diagnosis: the figure that explains a flight's decision.

:func:`plot_diagnosis` shows the measured spectrogram against the calibrated paper's
model (baseline) and the model extended by the named cause, the residual (measured -
baseline) and the statistic that named the cause (or the strongest test when none
was named)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..synthesis.extensions import ExtensionSet
from ..synthesis.model import Track, add_noise
from .config import DiagnosisConfig
from .decide import Decision
from .measure import DB, Measurements, simulate_blades, stft_power


def simulate_flight(flight, M: Measurements, ext: ExtensionSet | None, seed: int, n_fft: int) -> np.ndarray:
    """The paper's model of ``flight`` (calibrated), optionally extended, plus the
    flight's background recording (or white noise at its floor)."""
    prf = flight.prf_hz
    n = len(flight.iq)
    w2 = float((M.stft.window ** 2).sum())
    good = M.valid & (M.body_pow > 0)
    amp = float(np.sqrt(np.median(M.body_pow[good]) / (n_fft * w2))) if good.any() else 1.0
    calib, log = M.calib, M.log
    s_blade = calib.s_blade if np.isfinite(calib.s_blade) else 0.0
    alpha = calib.alpha_s if np.isfinite(calib.alpha_s) else 0.0
    a = flight.attrs
    lg = ext.transform_log(log) if ext is not None else log
    extensions = ext.model_extensions(prf_hz=prf, n_pulses=n, seed=seed) if ext is not None else None
    track = Track.from_tracker(flight.track_time_s, flight.track_range_m, flight.track_radial_velocity_mps)
    iq, _ = simulate_blades(lg, n, prf, wavelength_m=flight.wavelength_m, n_blades=int(a["n_blades"]),
                            blade_length_m=float(a["blade_length_m"]), n_fft=n_fft, seed=seed,
                            extensions=extensions, alpha_s=alpha, s_blade=amp * s_blade, s_body=amp, track=track)
    if ext is not None:
        iq = ext.post(iq, prf_hz=prf, seed=seed)
    if flight.background_iq is not None:
        iq = iq + flight.background_iq
    else:
        floor = float(np.median(M.floor)) / w2
        iq = add_noise(iq.astype(np.complex64), floor, seed + 1)
    return iq.astype(np.complex64)


def plot_diagnosis(flight, M: Measurements, D: Decision, path, cfg: DiagnosisConfig) -> Path:
    """Write the figure of ``flight``'s diagnosis (its measurement ``M`` and decision
    ``D``) to ``path`` (PNG, atomically); returns the path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tests, cause = D.shown, D.cause
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    base_iq = simulate_flight(flight, M, None, cfg.seed, cfg.n_fft)
    ext = ExtensionSet({cause: tests[cause].params}) if cause != "none" else None
    ext_iq = simulate_flight(flight, M, ext, cfg.seed, cfg.n_fft) if ext else base_iq
    st = M.stft
    sb = stft_power(base_iq, flight.prf_hz, cfg.n_fft)
    se = stft_power(ext_iq, flight.prf_hz, cfg.n_fft) if ext else sb
    h = float(np.median(M.f_log_hz)) * int(flight.attrs["n_blades"])
    fc = float(np.median(M.f_body_hz))
    sel = np.abs(st.f_hz - fc) <= 4.5 * h
    f = st.f_hz[sel]
    ext_t = [st.t_s[0], st.t_s[-1], f[0], f[-1]]
    ref = DB * np.log(np.median(M.floor))
    fig, ax = plt.subplots(1, 5, figsize=(20, 5), constrained_layout=True)
    for a_, s_, title in ((ax[0], st, "measured"), (ax[1], sb, "baseline (paper model)"),
                          (ax[2], se, f"extended ({cause})")):
        im = a_.imshow((DB * np.log(s_.p[:, sel] + 1e-30) - ref).T, origin="lower", aspect="auto", extent=ext_t,
                       vmin=-5, vmax=45, cmap="viridis")
        a_.set_title(title)
        a_.set_xlabel("time [s]")
    ax[0].set_ylabel("Doppler [Hz]")
    fig.colorbar(im, ax=ax[2], label="dB over floor")
    res = DB * np.log((st.p[:, sel] + 1e-30) / (sb.p[:, sel] + 1e-30))
    im2 = ax[3].imshow(res.T, origin="lower", aspect="auto", extent=ext_t, vmin=-10, vmax=10, cmap="RdBu_r")
    ax[3].set_title("residual: measured - baseline [dB]")
    ax[3].set_xlabel("time [s]")
    fig.colorbar(im2, ax=ax[3])
    show = cause if cause != "none" else max((t for t in tests.values() if t.testable),
                                             key=lambda t: t.log_e, default=None)
    show = tests[show] if isinstance(show, str) else show
    if show is not None and show.series:
        s = show.series
        ax[4].plot(s["t_s"], s["stat"], ".", ms=3, label="measured")
        if show.cause in ("sideband_fading", "body_fluctuation"):
            ax[4].fill_between(s["t_s"], -2 * s["base"], 2 * s["base"], alpha=0.3, label="baseline 95%")
            ax[4].plot(s["t_s"], 2 * s["ext"], "r--", lw=1, label="extended 95%")
            ax[4].plot(s["t_s"], -2 * s["ext"], "r--", lw=1)
        else:
            ax[4].plot(s["t_s"], s["base"], "k-", label="baseline")
            ax[4].plot(s["t_s"], s["ext"], "r-", label="extended")
        ax[4].legend(fontsize=8)
    ax[4].set_title(f"{show.cause if show else ''}: {show.statistic if show else ''}\n"
                    f"log e-value {show.log_e:.1f}" if show else "no statistic", fontsize=9)
    ax[4].set_xlabel("time [s]")
    fig.suptitle(f"{flight.flight_id}: diagnosis = {cause}")
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=80)
    plt.close(fig)
    tmp.replace(path)
    return path
