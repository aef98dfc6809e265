"""The I/Q balance of a receiver, measured so that the target does not count.

A receiver whose I and Q channels differ in gain (``g``) or are not in quadrature
(phase error ``phi``) turns a baseband signal ``s`` into ``mu s + nu conj(s)`` with
``mu = (1 + g e^{j phi}) / 2`` and ``nu = (1 - g e^{-j phi}) / 2`` (for
``I + j g (Q cos phi + I sin phi)``): every line at ``f`` gets a mirror image at
``-f``, ``|nu / mu|^2`` below it. The image-rejection ratio IRR = ``|mu / nu|^2`` is
tens of dB for a good receiver; 1 dB of gain error reads 24.8 dB, 5 deg of phase
error 27.2 dB, a real-valued signal (Q = 0, or I = Q) 0 dB.

The mirror image must be told apart from what the target itself puts at ``-f``. A
rotor seen with its body at 0 Hz (a drone hovering, on a stand, a staring radar) has
a mirror-symmetric spectrum by nature: two opposite blades give
``exp(j b sin wt) + exp(-j b sin wt)``, a real signal. So the balance is measured
only where the target cannot imitate an image:

1. ``samples``: I or Q identically zero, or I and Q proportional (a real-valued
   recording): 0 dB, whatever the target;
2. ``background``: the target-free recording of the same cells (``background/iq``),
   every Doppler bin against its mirror outside the clutter notch (noise is circular,
   so any coherence between ``f`` and ``-f`` is the receiver's);
3. ``noise segment``: a stretch of the recording that the user says holds no target,
   measured the same way;
4. ``body line``: the body's line at ``f_b`` against its image at ``-f_b``, when the
   body is well away from 0 Hz (at least ``body_min_bins`` Doppler bins and outside
   the ``notch_hz`` clutter notch, plus 3 bins; the fixed settings are the fields of
   :class:`IQBalanceSettings`). Its Doppler comes from
   the track (``-2 v / lambda``) or, for a constant-range track, from the spectrum
   (the strongest line outside the notch, accepted only where its mirror is at least
   ``body_accept_db`` weaker, which a mirror-symmetric rotor never is). The ratio
   ``conj(Z(-f_b)) / Z(f_b)`` is averaged coherently over segments, so the target's
   own content at ``-f_b`` (blades, whose phase turns with the rotor) averages out.

Otherwise the balance is "not measurable" and nothing is warned. Each measurement
carries its standard error; it counts only when it resolves an IRR
``resolution_margin_db`` above the warning level (so a balanced receiver reads no
false warning), else the next source is tried.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..configfields import check_ranges, knob
from ..spectra.periodogram import stft


@dataclass(frozen=True)
class IQBalanceSettings:
    """The fixed settings of the I/Q balance measurement and its warnings, each
    described by its field. No configuration key sets them (``config=False``);
    :func:`iq_sanity`, :func:`mirror_balance`, :func:`body_balance` and
    :func:`sanity_warnings` take an instance as ``settings`` (default: these defaults).
    """

    image_rejection_warn_db: float = knob(
        30.0,
        "Warn when the receiver's image-rejection ratio is below this [dB]; 1 dB of gain error alone reads "
        "24.8 dB, 5 deg of phase error alone 27.2 dB.",
        config=False,
    )
    real_valued_db: float = knob(
        3.0, "Below this image-rejection ratio [dB] the warning says 'as for a real-valued signal'.", config=False
    )
    doppler_sign_warn_db: float = knob(
        -3.0, "Warn when the target's Doppler is this much stronger on the mirrored side [dB].", config=False
    )
    resolution_margin_db: float = knob(
        6.0,
        "A measurement counts when 2 standard errors of |nu/mu| lie this far below the warning level [dB].",
        minimum=0,
        config=False,
    )
    body_min_bins: int = knob(
        8, "The body line is used only this many Doppler bins or more away from 0 Hz ...", minimum=0, config=False
    )
    notch_hz: float = knob(20.0, "... and outside this clutter notch [Hz] by 3 bins.", minimum=0, config=False)
    body_accept_db: float = knob(
        10.0,
        "A spectral peak (no track Doppler) is taken for the body only where its mirror is this much weaker [dB] ...",
        config=False,
    )
    body_line_db: float = knob(20.0, "... and it stands this far above the segment's median bin [dB].", config=False)
    body_min_segments: int = knob(8, "Segments needed for a body-line measurement.", minimum=1, config=False)
    noise_min_segments: int = knob(
        2, "Segments needed for a mirror (noise / background) measurement.", minimum=1, config=False
    )
    notch_excess: float = knob(
        4.0,
        "A background bin next to 0 Hz belongs to the clutter notch while its mean power exceeds the median bin "
        "this much.",
        exclusive_minimum=0,
        config=False,
    )

    def __post_init__(self):
        check_ranges(self, "importing.iqbalance", all_fields=True)


KEYS = (
    "image_rejection_db",
    "amplitude_imbalance_db",
    "phase_imbalance_deg",
    "image_rejection_from",
    "image_rejection_floor_db",
    "image_rejection_note",
    "doppler_sign_db",
)


def _segments(iq: np.ndarray, nfft: int, max_segments: int = 1024) -> tuple[np.ndarray, np.ndarray]:
    """Blackman-Harris windowed FFTs (the one kernel,
    :func:`microdoppler.spectra.periodogram.stft`) of up to ``max_segments``
    half-overlapping segments spread over ``iq`` (complex [n]), each less its mean,
    shape [n_seg, nfft], and their centre sample indices. (Removing the mean and the window's low
    sidelobes keep a strong clutter line, whose leakage at +-f is mirror-symmetric,
    out of the bins beside the notch; the overlap recovers what the window's tails
    discard.)"""
    hop = nfft // 2
    starts = np.arange(0, len(iq) - nfft + 1, hop)
    idx = np.unique(np.linspace(0, len(starts) - 1, min(len(starts), max_segments)).round().astype(int))
    starts = starts[idx]
    # demean: the static clutter line removed before its sidelobes reach every bin
    return stft(iq, nfft, starts=starts, demean=True), starts + nfft / 2


def _nfft_for(n: int, nfft: int) -> int:
    return int(min(nfft, 2 ** int(np.floor(np.log2(max(n, 1))))))


def real_valued(iq: np.ndarray) -> str | None:
    """How ``iq`` (complex [n]) is real-valued, or None: Q (or I) identically zero, or
    I and Q proportional (correlation 1 to 1e-9 after removing their means)."""
    x = np.asarray(iq, np.complex128)
    i, q = x.real - x.real.mean(), x.imag - x.imag.mean()
    ei, eq = float(np.dot(i, i)), float(np.dot(q, q))
    if ei == 0 and eq == 0:
        return None
    if eq <= 1e-18 * ei:
        return "Q is zero"
    if ei <= 1e-18 * eq:
        return "I is zero"
    rho = float(np.dot(i, q)) / math.sqrt(ei * eq)
    if abs(rho) > 1 - 1e-9:
        return "I and Q are proportional"
    return None


def _from_ratio(r: float) -> float:
    """IRR [dB] from ``|nu / mu|`` (capped at 100 dB)."""
    return 100.0 if r <= 1e-5 else max(0.0, -20 * math.log10(r))


def _mirror_stat(Z: np.ndarray, keep: np.ndarray, settings: IQBalanceSettings | None = None) -> dict | None:
    """The mirror statistic of windowed spectra ``Z`` [n_seg, nfft] over the bins
    ``keep`` (bool [nfft], symmetric about 0 Hz).

    The statistic is ``rho = sum_s,f w_f Z(f) Z(-f) / sum_s,f w_f (|Z(f)|^2 + |Z(-f)|^2) / 2``
    with ``w_f = 1 / (P(f) + P(-f))``, ``P`` the mean power of a bin over the
    segments: each bin pair counts alike on average, so a few strong lines do not
    outweigh every other bin, and the weights do not depend on the segment (no bias).
    Its expectation is ``2 mu nu / (|mu|^2 + |nu|^2)`` whatever the power at ``f`` and
    ``-f``, provided the signal at ``-f`` is not coherent with the one at ``f`` (noise,
    or a target whose spectrum is not mirror-symmetric about 0 Hz). Returns
    ``r = |nu / mu|`` (from ``|rho| = 2 r / (1 + r^2)``), its standard error ``se_r``
    (from the scatter of the per-segment sums), and the amplitude [dB] and phase
    [deg] imbalance; None when no bin pair is left (or fewer than ``settings``'s
    ``noise_min_segments`` segments).
    """
    s = settings or IQBalanceSettings()
    nfft = Z.shape[1]
    mirror = (-np.arange(nfft)) % nfft
    a, b = Z[:, keep], Z[:, mirror][:, keep]
    pa, pb = np.abs(a) ** 2, np.abs(b) ** 2
    pbar = pa.mean(axis=0) + pb.mean(axis=0)
    if len(Z) < s.noise_min_segments or not np.any(pbar > 0):
        return None
    w = np.where(pbar > 0, 1 / np.where(pbar > 0, pbar, 1.0), 0.0)
    c = (a * b) @ w
    p = ((pa + pb) / 2) @ w
    P = float(p.sum())
    rho = complex(c.sum()) / P
    e = c - rho * p
    ee = float(np.sum(np.abs(e) ** 2))
    # neighbouring (half-overlapping) segments are correlated: inflate by 1 + 2 x lag-1 correlation
    lag1 = float(np.real(np.sum(e[1:] * np.conj(e[:-1])))) / ee if ee > 0 and len(e) > 2 else 0.0
    se_rho = math.sqrt(ee * max(1.0, 1 + 2 * lag1)) / P
    kappa = min(abs(rho), 1.0)
    r = 0.0 if kappa == 0 else (1 - math.sqrt(max(0.0, 1 - kappa**2))) / kappa
    ei, eq, eiq = (1 + rho.real) / 2, (1 - rho.real) / 2, rho.imag / 2
    amp = phase = None
    if ei > 1e-12 and eq > 1e-12:
        amp = 10 * math.log10(ei / eq)
        phase = math.degrees(math.asin(max(-1.0, min(1.0, eiq / math.sqrt(ei * eq)))))
    # d r / d kappa = r / (kappa sqrt(1 - kappa^2)) -> 1/2 for small kappa
    dr = 0.5 if kappa < 1e-6 else r / (kappa * math.sqrt(max(1e-12, 1 - kappa**2)))
    return {
        "r": r,
        "se_r": se_rho * dr,
        "amplitude_imbalance_db": amp,
        "phase_imbalance_deg": phase,
        "n_segments": int(len(Z)),
    }


def mirror_balance(
    iq: np.ndarray, nfft: int = 1024, guard_bins: int = 4, *, settings: IQBalanceSettings | None = None
) -> dict | None:
    """The receiver's balance from a target-free recording (noise and clutter).

    Parameters
    ----------
    iq : ndarray, complex [n]
        Slow-time samples holding no target (a background recording, a noise stretch).
    nfft : int
        Segment length [samples] (shortened to a power of two <= n).
    guard_bins : int
        Bins next to 0 Hz always left out; the notch widens while the mean power of a
        bin or its mirror exceeds ``settings.notch_excess`` times the median bin
        (clutter, whose spread about 0 Hz may be mirror-symmetric).
    settings : IQBalanceSettings, optional
        The fixed settings (default: :class:`IQBalanceSettings`'s defaults).

    Returns
    -------
    dict or None
        ``r`` (``|nu / mu|``), ``se_r`` (its standard error), ``amplitude_imbalance_db``
        (10 log10 E[I^2] / E[Q^2]), ``phase_imbalance_deg`` (asin of the I-Q
        correlation), ``notch_bins``, ``n_segments`` (see :func:`_mirror_stat`); None
        when too short.
    """
    s = settings or IQBalanceSettings()
    nfft = _nfft_for(len(iq), nfft)
    if nfft < 64 or len(iq) // nfft < s.noise_min_segments:
        return None
    Z, _ = _segments(iq, nfft)
    k = (np.fft.fftfreq(nfft) * nfft).astype(int)
    pw = np.mean(np.abs(Z) ** 2, axis=0)
    floor = float(np.median(pw))
    notch = guard_bins
    while notch < nfft // 4 and max(pw[notch], pw[-notch]) > s.notch_excess * floor:
        notch += 1
    m = _mirror_stat(Z, (np.abs(k) >= notch) & (np.abs(k) < nfft // 2), s)
    if m is not None:
        m["notch_bins"] = int(notch)
    return m


def body_balance(
    iq: np.ndarray,
    prf_hz: float,
    body_doppler_hz=None,
    nfft: int = 1024,
    guard_bins: int = 4,
    *,
    settings: IQBalanceSettings | None = None,
) -> dict:
    """The receiver's balance from the segments whose body line lies well away from 0 Hz.

    Parameters
    ----------
    iq : ndarray, complex [n]
        The target's slow-time samples at ``prf_hz`` [Hz].
    body_doppler_hz : callable or None
        Body Doppler [Hz] at given times [s] (from the track: ``-2 v / lambda``); the
        peak within 3 bins of it is the body. None: the strongest line outside the
        notch, where its mirror is ``settings.body_accept_db`` weaker and it stands
        ``settings.body_line_db`` above the segment's median bin.
    nfft : int
        Segment length [samples].
    settings : IQBalanceSettings, optional
        The fixed settings (default: :class:`IQBalanceSettings`'s defaults).

    Returns
    -------
    dict
        As :func:`_mirror_stat` over the segments whose body is at least
        ``settings.body_min_bins`` bins and the ``settings.notch_hz`` notch plus 3 bins
        away from 0 Hz (bins inside that notch left out), with ``body_from``; or
        ``reason`` (str) when fewer than ``settings.body_min_segments`` such segments
        exist.

    Notes
    -----
    A target's own spectrum is mirror-symmetric about its body Doppler ``f_b`` (the
    blades' lines at ``f_b +- n f_rot``), not about 0 Hz: the content at ``-f`` that
    pairs with ``f`` is a line of another order, whose phase turns with the rotor and
    the range from segment to segment, so it averages out. The body line's own pair
    ``(f_b, -f_b)`` is the line and its image: ``Z(-f_b) = nu conj(A)`` for
    ``Z(f_b) = mu A``.
    """
    s = settings or IQBalanceSettings()
    nfft = _nfft_for(len(iq), nfft)
    if nfft < 64:
        return {"reason": f"too short ({len(iq)} samples)"}
    Z, centres = _segments(iq, nfft)
    df = prf_hz / nfft
    notch = max(guard_bins, int(math.ceil(s.notch_hz / df)))
    kmin = max(s.body_min_bins, notch + 3)
    kmax = nfft // 2 - 3
    rows = np.arange(len(Z))
    pw = np.abs(Z) ** 2
    k = (np.fft.fftfreq(nfft) * nfft).astype(int)
    if body_doppler_hz is not None:
        fd = np.asarray(body_doppler_hz(centres / prf_hz), np.float64)
        fd = (fd + prf_hz / 2) % prf_hz - prf_hz / 2
        kp = np.round(fd / df).astype(int)
        cand = kp[:, None] + np.arange(-3, 4)
        ks = cand[rows, np.argmax(pw[rows[:, None], cand % nfft], axis=1)]
        ok = (np.abs(ks) >= kmin) & (np.abs(ks) <= kmax)
        how = "the track's body Doppler"
        need = s.body_min_segments
    else:
        allowed = (np.abs(k) >= kmin) & (np.abs(k) <= kmax)
        ks = k[np.argmax(np.where(allowed[None, :], pw, -1.0), axis=1)]
        at, mir = pw[rows, ks % nfft], pw[rows, (-ks) % nfft]
        med = np.median(pw, axis=1)
        ok = (at >= 10 ** (s.body_accept_db / 10) * mir) & (at >= 10 ** (s.body_line_db / 10) * med)
        how = "the strongest line"
        need = max(s.body_min_segments, int(math.ceil(0.5 * len(Z))))
        if ok.sum() < need:
            return {
                "reason": (
                    f"no body line away from 0 Hz: in {int(ok.sum())} of {len(Z)} segments the strongest "
                    f"line beyond {kmin * df:.0f} Hz stands {s.body_line_db:g} dB above the floor with a "
                    f"mirror image >= {s.body_accept_db:g} dB weaker ({need} needed; a hovering or staring "
                    f"target's spectrum is mirror-symmetric about 0 Hz)"
                )
            }
    if ok.sum() < need:
        return {
            "reason": (
                f"the body ({how}) lies within {kmin * df:.0f} Hz of 0 Hz in {int((~ok).sum())} of "
                f"{len(Z)} segments ({int(ok.sum())} usable, {need} needed)"
            )
        }
    m = _mirror_stat(Z[ok], (np.abs(k) >= notch) & (np.abs(k) < nfft // 2), s)
    if m is None:
        return {"reason": "no bin pair outside the clutter notch"}
    m["body_from"] = how
    return m


def _doppler_sign(iq, prf_hz, wavelength_m, track, nfft=1024, guard_bins=4):
    """Median over segments of the power near the track's Doppler over that near its
    mirror image [dB], or None."""
    nfft = _nfft_for(len(iq), nfft)
    if nfft < 64 or track is None or not wavelength_m:
        return None
    Z, centres = _segments(iq, nfft)
    tc = centres / prf_hz
    fd = -2 * np.interp(tc, track["time_s"], track["radial_velocity_mps"]) / wavelength_m
    kb = np.round(fd / prf_hz * nfft).astype(int)
    ok = (np.abs(kb) >= guard_bins + 3) & (np.abs(kb) < nfft // 2 - 3)
    if ok.sum() < 3:
        return None
    pw = np.abs(Z[ok]) ** 2
    off = np.arange(-3, 4)
    rows = np.arange(len(pw))[:, None]
    at = pw[rows, (kb[ok][:, None] + off) % nfft].max(axis=1)
    mir = pw[rows, (-kb[ok][:, None] + off) % nfft].max(axis=1)
    good = (at > 0) & (mir > 0)
    if good.sum() < 3:
        return None
    return float(np.median(10 * np.log10(at[good] / mir[good])))


def _round(v, digits=3):
    return None if v is None or not math.isfinite(v) else round(float(v), digits)


def iq_sanity(
    iq: np.ndarray,
    prf_hz: float,
    wavelength_m: float | None = None,
    track: dict | None = None,
    *,
    background: np.ndarray | None = None,
    noise_s: tuple[float, float] | None = None,
    nfft: int = 1024,
    guard_bins: int = 4,
    settings: IQBalanceSettings | None = None,
) -> dict:
    """The receiver's I/Q balance and the Doppler sign of a recording.

    Parameters
    ----------
    iq : ndarray, complex [n]
        The target's slow-time samples at ``prf_hz`` [Hz].
    wavelength_m : float, optional
        Carrier wavelength [m] (for the track's Doppler).
    track : dict, optional
        ``time_s``, ``radial_velocity_mps`` arrays; its Doppler ``-2 v / lambda`` places
        the body line and the Doppler-sign check.
    background : ndarray, complex [n_bg], optional
        A target-free recording of the same cells.
    noise_s : (float, float), optional
        ``[start, end)`` [s] of a stretch of ``iq`` that holds no target.
    settings : IQBalanceSettings, optional
        The fixed settings (default: :class:`IQBalanceSettings`'s defaults).

    Returns
    -------
    dict
        ``image_rejection_db`` (IRR [dB]), ``amplitude_imbalance_db`` and
        ``phase_imbalance_deg`` of the receiver, ``image_rejection_from`` (``samples``,
        ``background``, ``noise segment`` or ``body line``; None when not measurable),
        ``image_rejection_floor_db`` (the IRR that two standard errors of the
        measurement allow: a balanced receiver reads about this or more),
        ``image_rejection_note`` (why it is not measurable, or which sources were
        tried first), ``doppler_sign_db`` (median over segments of the power near
        the track's Doppler over that near its mirror [dB]; negative when I and Q are
        swapped). The module docstring says which source is used when.
    """
    settings = settings or IQBalanceSettings()
    out = dict.fromkeys(KEYS)
    out["doppler_sign_db"] = _doppler_sign(iq, prf_hz, wavelength_m, track, nfft, guard_bins)
    how = real_valued(iq)
    if how is not None:
        out.update(image_rejection_db=0.0, image_rejection_from="samples", image_rejection_note=how)
        return {k: (_round(v) if isinstance(v, float) else v) for k, v in out.items()}
    need_se = 10 ** (-(settings.image_rejection_warn_db + settings.resolution_margin_db) / 20) / 2
    tried = []

    def take(m, source):
        out.update(
            image_rejection_db=_from_ratio(m["r"]),
            amplitude_imbalance_db=m["amplitude_imbalance_db"],
            phase_imbalance_deg=m["phase_imbalance_deg"],
            image_rejection_from=source,
            image_rejection_floor_db=_from_ratio(2 * m["se_r"]),
            image_rejection_note="; ".join(tried) or None,
        )

    for source, x in (
        ("background", background),
        (
            "noise segment",
            None if noise_s is None else iq[max(0, int(round(noise_s[0] * prf_hz))) : int(round(noise_s[1] * prf_hz))],
        ),
    ):
        if x is None:
            continue
        if real_valued(x):
            out.update(image_rejection_db=0.0, image_rejection_from=source, image_rejection_note=real_valued(x))
            return {k: (_round(v) if isinstance(v, float) else v) for k, v in out.items()}
        m = mirror_balance(x, nfft, guard_bins, settings=settings)
        if m is None:
            tried.append(f"{source} too short ({len(x)} samples)")
        elif m["se_r"] > need_se:
            tried.append(f"{source} too noisy a measure (floor {_from_ratio(2 * m['se_r']):.1f} dB)")
        else:
            take(m, source)
            break
    else:
        body = None
        if track is not None and wavelength_m and np.any(np.asarray(track["radial_velocity_mps"]) != 0):
            t, v = np.asarray(track["time_s"]), np.asarray(track["radial_velocity_mps"])
            body = lambda ts: -2 * np.interp(ts, t, v) / wavelength_m  # noqa: E731
        m = body_balance(iq, prf_hz, body, nfft, guard_bins, settings=settings)
        if "reason" in m:
            tried.append(m["reason"])
        elif m["se_r"] > need_se:
            tried.append(f"body line too weak a measure (floor {_from_ratio(2 * m['se_r']):.1f} dB)")
        else:
            take(m, "body line")
        if out["image_rejection_from"] is None:
            out["image_rejection_note"] = "not measurable: " + "; ".join(tried)
    return {k: (_round(v) if isinstance(v, float) else v) for k, v in out.items()}


def sanity_warnings(s: dict, settings: IQBalanceSettings | None = None) -> list[str]:
    """Warnings (one line each) for a doubtful balance or a mirrored Doppler in ``s``
    (an :func:`iq_sanity` result), at ``settings``'s levels (default:
    :class:`IQBalanceSettings`'s)."""
    st = settings or IQBalanceSettings()
    w = []
    irr = s.get("image_rejection_db")
    if irr is not None and irr < st.image_rejection_warn_db:
        amp, ph = s.get("amplitude_imbalance_db"), s.get("phase_imbalance_deg")
        src = s.get("image_rejection_from")
        detail = (
            f"amplitude imbalance {amp:.1f} dB, phase imbalance {ph:.1f} deg"
            if amp is not None and ph is not None
            else (s.get("image_rejection_note") or "one of I, Q is zero")
        )
        where = {
            "samples": "",
            "background": ", measured on the background recording",
            "noise segment": ", measured on the noise segment",
            "body line": ", measured on the body line's mirror image",
        }.get(src, "")
        head = f"I/Q image rejection is {irr:.1f} dB ({detail}{where}; expected > {st.image_rejection_warn_db:g} dB): "
        if irr < st.real_valued_db:
            w.append(head + "the spectrum is nearly mirror-symmetric, as for a real-valued signal (Q = 0 or I = Q)")
        else:
            w.append(
                head + f"the receiver's I and Q are unbalanced; every line has a mirror image at -f, {irr:.0f} dB down"
            )
    d = s.get("doppler_sign_db")
    if d is not None and d < st.doppler_sign_warn_db:
        w.append(
            f"the target's Doppler is {-d:.1f} dB stronger at the mirror of the track's -2 v / lambda: "
            "I and Q look swapped (or Q negated); expected an approaching target at positive Doppler"
        )
    return w
