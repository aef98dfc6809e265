"""Figures of the simulator: paper Fig. 2 (HERM lines for three choices of motor
speeds) and a Fig. 8-style comparison of per-CPI and sub-CPI motor-speed sampling.

All figures use the Agg backend (no display). :func:`plot_spectrogram` is the one
false-colour spectrogram plot of the project (Doppler on y, time on x).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .io.motorlog import MotorLog, read_motor_log  # noqa: E402
from .synthesis.radar import Radar  # noqa: E402
from .rotors.sampling import SamplingConfig, per_cpi, sub_cpi  # noqa: E402
from .spectra.spectrogram import Spectrogram, SpectrogramConfig, spectrogram  # noqa: E402
from .synthesis.model import Scaling, SynthesisConfig, Track, add_noise, synthesize  # noqa: E402

#: paper-like false colour (blue floor, red lines)
CMAP = "jet"


def plot_spectrogram(
    ax, spec: Spectrogram, *, dynamic_range_db: float = 60.0, title: str | None = None, colorbar: bool = False
):
    """Draw ``spec`` on ``ax``: time [s] on x, Doppler [Hz] on y, dB in false colour.

    The colour scale spans ``dynamic_range_db`` below the spectrogram's maximum.

    Parameters
    ----------
    ax : matplotlib Axes
    spec : Spectrogram
        ``power_db`` float [n_timesteps, n_bins].
    dynamic_range_db : float
        Colour range below the peak [dB].
    title : str, optional
    colorbar : bool
        Add a colour bar labelled in dB.

    Returns
    -------
    matplotlib.image.AxesImage
    """
    if not dynamic_range_db > 0:
        raise ValueError(f"dynamic_range_db={dynamic_range_db} must be > 0")
    p = np.asarray(spec.power_db, dtype=np.float32)
    vmax = float(np.max(p))
    t = np.asarray(spec.time_s, dtype=np.float64)
    f = np.asarray(spec.doppler_hz, dtype=np.float64)
    dt = t[1] - t[0] if len(t) > 1 else 1.0
    df = f[1] - f[0] if len(f) > 1 else 1.0
    extent = (t[0] - dt / 2, t[-1] + dt / 2, f[0] - df / 2, f[-1] + df / 2)
    im = ax.imshow(
        p.T,
        origin="lower",
        aspect="auto",
        extent=extent,
        cmap=CMAP,
        vmin=vmax - dynamic_range_db,
        vmax=vmax,
        interpolation="nearest",
    )
    ax.set_xlabel("time [s]")
    ax.set_ylabel("Doppler [Hz]")
    if title:
        ax.set_title(title)
    if colorbar:
        ax.figure.colorbar(im, ax=ax, label="power [dB]")
    return im


def _wavy_track(duration_s: float, range_m: float | None = None) -> Track:
    """An arbitrary smooth radial-velocity profile (Fig. 2 uses one): v = -4 + 2 sin(2 pi t / 12) m/s,
    starting at ``range_m`` (default far enough that the approach never reaches the
    radar: 600 m, or 100 m plus 5 m per second of a longer log)."""
    if range_m is None:
        range_m = max(600.0, 100.0 + 5.0 * duration_s)
    t = np.linspace(0.0, duration_s, max(16, int(duration_s * 4)))
    r = range_m - 4.0 * t - 2.0 * 12 / (2 * np.pi) * (1 - np.cos(2 * np.pi * t / 12))
    return Track(t, r)


def _load_log(motor_log) -> MotorLog:
    if isinstance(motor_log, MotorLog):
        log = motor_log
    else:
        log = read_motor_log(motor_log)
    return log.shifted(-float(log.time_s[0]))


def fig2(
    out_png,
    *,
    ulog_path,
    prf_hz: float = 7000.0,
    carrier_hz: float = 1.35e9,
    blade_length_m: float = 0.19,
    n_blades: int = 2,
    duration_s: float = 20.0,
    seed: int = 0,
    n_bins: int = 1200,
) -> Path:
    """Paper Fig. 2: HERM lines of eq. (1) (blades only, no body) for (a) all four motors
    at 100 Hz, (b) 85/90/95/100 Hz, (c) the real logged speeds of ``ulog_path``
    (sub-CPI sampling). L = 0.19 m, PRF 7 kHz, Blackman-Harris 4096, 50 % overlap.
    """
    radar = Radar(prf_hz=prf_hz, carrier_hz=carrier_hz)
    log = _load_log(ulog_path)
    cfg = SpectrogramConfig(n_bins=n_bins)
    panels = []
    for label, speeds, dur in (
        ("(a) all motors 100 Hz", [100.0] * 4, duration_s),
        ("(b) motors 85, 90, 95, 100 Hz", [85.0, 90.0, 95.0, 100.0], duration_s),
        ("(c) real logged motor speeds", None, log.duration_s),
    ):
        n = int(dur * prf_hz)
        if speeds is None:
            rev_s = sub_cpi(log, n, prf_hz, SamplingConfig(n_fft=radar.n_fft))
        else:
            rev_s = np.broadcast_to(np.asarray(speeds, np.float32), (n, 4))
        config = SynthesisConfig.of(
            prf_hz=prf_hz,
            wavelength_m=radar.wavelength_m,
            n_blades=n_blades,
            blade_length_m=blade_length_m,
            scaling=Scaling(0.0, 1.0, 0.0),
        )
        iq = synthesize(config, _wavy_track(dur), rev_s, seed=seed)
        panels.append((label, spectrogram(iq, prf_hz, cfg)))
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.8), constrained_layout=True)
    for ax, (label, spec) in zip(axes, panels):
        im = plot_spectrogram(ax, spec, dynamic_range_db=60, title=label)
    fig.colorbar(im, ax=axes, label="power [dB]", shrink=0.9)
    fig.suptitle(
        f"Fig. 2: thin-wire HERM lines, L = {blade_length_m} m, {n_blades} blades, PRF {prf_hz:g} Hz, "
        f"{carrier_hz / 1e9:g} GHz, Blackman-Harris {radar.n_fft}, 50 % overlap"
    )
    return _save(fig, out_png)


def fig8(
    out_png,
    *,
    motor_log,
    prf_hz: float = 7300.0,
    carrier_hz: float = 1.35e9,
    blade_length_m: float = 0.19,
    n_blades: int = 2,
    alpha_s: float = 2e-3,
    s_blade: float = 3.0,
    snr_db: float = 10.0,
    window_pulses: int = 2500,
    seed: int = 0,
) -> Path:
    """Fig. 8 style: per-CPI vs sub-CPI motor-speed sampling of ``motor_log`` (a
    :class:`MotorLog` or a log file): the speed traces of motor 0 (raw log, one value
    per CPI, sub-CPI) and the two resulting spectrograms (body approaching at 4 m/s
    on average, alpha envelope, noise at ``snr_db`` per pulse).
    """
    radar = Radar(prf_hz=prf_hz, carrier_hz=carrier_hz)
    log = _load_log(motor_log)
    n = int(log.duration_s * prf_hz)
    scfg = SamplingConfig(n_fft=radar.n_fft, window_pulses=window_pulses)
    speeds = {"per-CPI": per_cpi(log, n, prf_hz, scfg), "sub-CPI": sub_cpi(log, n, prf_hz, scfg)}
    track = _wavy_track(log.duration_s)
    specs = {}
    for k, (name, rev_s) in enumerate(speeds.items()):
        config = SynthesisConfig.of(
            prf_hz=prf_hz,
            wavelength_m=radar.wavelength_m,
            n_blades=n_blades,
            blade_length_m=blade_length_m,
            scaling=Scaling(1.0, s_blade, alpha_s),
        )
        iq = synthesize(config, track, rev_s, seed=seed)
        add_noise(iq, 10 ** (-snr_db / 10), seed + 1)
        specs[name] = spectrogram(iq, prf_hz, SpectrogramConfig())
    t = np.arange(n) / prf_hz
    fig = plt.figure(figsize=(14, 8.5), constrained_layout=True)
    gs = fig.add_gridspec(2, 2)
    ax = fig.add_subplot(gs[0, 0])
    ax.plot(log.time_s, log.rev_s[:, 0], "k.", ms=4, label=f"log ({len(log.time_s) / log.duration_s:.1f} Hz)")
    ax.plot(t, speeds["per-CPI"][:, 0], "r-", lw=1.2, label="per-CPI (cubic spline, 1 per CPI)")
    ax.plot(t, speeds["sub-CPI"][:, 0], "g-", lw=1.2, label=f"sub-CPI (8 per CPI, {window_pulses}-pulse average)")
    for b in np.arange(0, n, radar.n_fft) / prf_hz:
        ax.axvline(b, color="0.85", lw=0.5, zorder=0)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("motor 0 speed [rev/s]")
    ax.set_title("(a) motor-speed sampling (grey: CPI boundaries)")
    ax.legend(fontsize=8)
    ax = fig.add_subplot(gs[0, 1])
    steps = {}
    for name, col in (("per-CPI", "r"), ("sub-CPI", "g")):
        d = np.abs(np.diff(speeds[name][:, 0].astype(np.float64)))
        ax.semilogy(t[1:], d + 1e-9, col, lw=0.8, label=name)
        at = np.zeros(len(d), bool)
        at[radar.n_fft - 1 :: radar.n_fft] = True
        steps[name] = (d[at].max(), d[~at].max())
    ax.set_xlabel("time [s]")
    ax.set_ylabel("|speed step| per pulse [rev/s]")
    ax.set_title(
        "(b) pulse-to-pulse steps: max at CPI boundaries / elsewhere\n"
        + ", ".join(f"{k}: {a:.3g} / {b:.3g}" for k, (a, b) in steps.items())
    )
    ax.legend(fontsize=8)
    for j, name in enumerate(specs):
        plot_spectrogram(
            fig.add_subplot(gs[1, j]),
            specs[name],
            dynamic_range_db=60,
            title=f"({'cd'[j]}) {name} synthetic spectrogram",
            colorbar=True,
        )
    fig.suptitle(
        f"Fig. 8 style: per-CPI vs sub-CPI sampling ({Path(log.source).name or 'motor log'}; "
        f"L = {blade_length_m} m, alpha = {alpha_s:g} s, S_blade = {s_blade:g}, SNR {snr_db:g} dB/pulse)"
    )
    return _save(fig, out_png)


def _save(fig, out_png) -> Path:
    out = Path(out_png)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    tmp.replace(out)
    return out
