"""Does a drone recording agree with its declared set-up? The checks of ``microdoppler
import`` that read the recording itself (the range checks that need only the declared
numbers: :mod:`microdoppler.importing.plausibility`).

A drone's blade tips turn at a tip speed v = 2 pi f L (rotation rate f [rev/s], blade
length L [m]) and return Doppler up to 2 v / lambda about the body's. Every limit
below is the rotor-order resolver's (:class:`~microdoppler.rotors.order.OrderConfig`),
not a new setting (the checks' own fixed settings, ``track_speed_tol_mps``,
``segment_s`` and ``max_segments``, are ``config=False`` fields of it too):

- the spectrum's Doppler extent (:func:`doppler_extent`: how far from the body the
  time-averaged spectrum stands ``line_db`` over its floor; the whole ±PRF/2 where it
  fills it, a lower bound then) must not pass what tips at the fastest plausible speed
  (``max_tip_mach`` times the speed of sound) reach: ``extent_range[1]`` x 2 v / lambda
  plus the thin-wire flash's Bessel tail, ``tail_harmonics`` beta^(1/3) rotation
  harmonics (beta = 4 pi L / lambda) at the fastest rate such tips allow (at most
  ``max_rev_s``). Wider lines mean the PRF (a frequency axis stretched) or the carrier
  (a wavelength too short) is off;
- a moving target's body: the centre of the spectrum's lines (the body line, about
  which the rotors' lines lie symmetric) against the track's Doppler -2 v / lambda
  (averaged over the recording), where the track moves: the centre or the strongest
  line (the body line, as a rule) must agree with it within the
  track's own spread over the recording, ``track_speed_tol_mps`` and three bins
  (the sign aside: a swapped I/Q is warned about separately). A body line at another
  Doppler means the PRF (the frequency axis) or the carrier (the wavelength) is off;
- with rotor speeds (estimated from the radar, ``--estimate-motors``, or logged): the
  tips' speed 2 pi f L must lie in :data:`~microdoppler.importing.plausibility.TIP_SPEED_RANGE_MPS`
  (at most ``max_tip_mach``) and the spectrum's lines must not pass the tips' Doppler
  at that rate (``extent_range[1]`` beta f plus the tail); an estimate's order
  alternatives count as well (a set-up is refused only where no rate the lines allow
  is plausible). A contradiction names ``n_blades``, ``blade_length_m``, ``prf_hz``
  (the rate) or ``carrier_hz`` (the tips' Doppler).

Each check returns ``(field, what the recording shows, expected)`` tuples, as
:func:`microdoppler.importing.plausibility.setup_problems`; empty where nothing contradicts.
A recording without visible lines (only noise or a clutter line) has no extent and
passes: the checks refuse what the recording contradicts, not what it cannot show.
"""

from __future__ import annotations

import math

import numpy as np

from ..importing.plausibility import SPEED_OF_LIGHT_MPS, TIP_SPEED_RANGE_MPS, _unit
from ..spectra.floor import FLOOR_PERCENTILE
from ..spectra.periodogram import periodogram
from .order import SOUND_MPS, OrderConfig


def _limits(ocfg: OrderConfig | None = None) -> tuple[OrderConfig, float]:
    ocfg = ocfg or OrderConfig()
    return ocfg, min(TIP_SPEED_RANGE_MPS[1], ocfg.max_tip_mach * SOUND_MPS)


def doppler_extent(iq: np.ndarray, prf_hz: float, *, ocfg: OrderConfig | None = None) -> dict | None:
    """How far the recording's time-averaged spectrum reaches from its body line.

    The mean Blackman-Harris periodogram of ``ocfg.segment_s`` segments (at most
    ``ocfg.max_segments``); a bin is
    occupied where it stands ``line_db`` over the floor (the spectrum's
    ``FLOOR_PERCENTILE``-th percentile), outside the clutter band (``clutter_guard_hz``
    about 0 Hz), and counts with its two neighbours each side. A rotor's lines lie
    symmetric about the body: the body is the centre about which most occupied bins
    pair, the extent the farthest distance from it at which both sides are occupied
    (a lone line, such as the body's image or a spur, has no partner).

    Returns
    -------
    dict or None
        ``extent_hz`` [Hz], ``centre_hz`` (the body) [Hz], ``peak_hz`` (the
        strongest line outside the clutter band: the body line, as a rule) [Hz], ``filled`` (the extent is
        ±PRF/2: a lower bound, the lines may fold), ``n_fft``; None where no bin
        outside the clutter band is occupied in pairs.
    """
    ocfg = ocfg or OrderConfig()
    iq = np.asarray(iq)
    n = len(iq)
    n_fft = int(min(4096, max(256, 2 ** round(math.log2(max(ocfg.segment_s * prf_hz, 1.0))))))
    if n < n_fft:
        n_fft = 2 ** int(math.log2(max(n, 2)))
        if n_fft < 64:
            return None
    starts = np.unique(np.linspace(0, n - n_fft, min(ocfg.max_segments, max(1, 2 * n // n_fft - 1))).astype(int))
    p = periodogram(iq, n_fft, starts=starts, demean=True, average=True)
    db = 10 * np.log10(p + 1e-30)
    floor = float(np.percentile(db, FLOOR_PERCENTILE))
    f = np.fft.fftfreq(n_fft, 1.0 / prf_hz)
    guard = np.abs(f) <= ocfg.clutter_guard_hz + 4 * prf_hz / n_fft  # the window's main lobe beyond it
    occ = (db >= floor + ocfg.line_db) & ~guard
    if not occ.any():
        return None
    # a bin counts with its neighbours (a line's main lobe, the rotors' spread)
    wide = occ | np.roll(occ, 1) | np.roll(occ, -1) | np.roll(occ, 2) | np.roll(occ, -2)
    # the centre of symmetry: the most occupied bins pairing about it (k and 2c - k), each
    # pair weighted by its bins' heights over the threshold (the body line pairs with itself)
    x = np.where(wide, 1.0 + np.clip(db - floor - ocfg.line_db, 0.0, None), 0.0)  # weighted by the height [dB]
    pairs = np.real(np.fft.ifft(np.fft.fft(x) ** 2))  # [m]: pairs with k + k' = m (mod n_fft)
    m = int(np.argmax(np.round(pairs, 6)))
    d = np.arange(1, n_fft // 2 + 1)

    def reach(c):
        """The farthest distance [bins] from ``c`` with both sides occupied (0: none)."""
        up = wide[np.floor(c + d).astype(int) % n_fft] | wide[np.ceil(c + d).astype(int) % n_fft]
        down = wide[np.floor(c - d).astype(int) % n_fft] | wide[np.ceil(c - d).astype(int) % n_fft]
        both = np.flatnonzero(up & down)
        return int(d[both[-1]]) if len(both) else 0

    # on the circle of bins a set symmetric about c is symmetric about c + n_fft / 2 too:
    # the body is the centre the lines lie near
    centre, reach_bins = min(((c, reach(c)) for c in (m / 2.0, m / 2.0 + n_fft / 2)), key=lambda x: x[1])
    if reach_bins == 0:
        return None
    # beyond the clutter band where it is the only occupied stretch
    filled = reach_bins >= n_fft // 2 - 2
    centre_hz = float(((centre / n_fft + 0.5) % 1.0 - 0.5) * prf_hz)
    peak = int(np.argmax(np.where(occ, db, -np.inf)))
    return {
        "extent_hz": float(reach_bins * prf_hz / n_fft),
        "centre_hz": centre_hz,
        "peak_hz": float(f[peak]),
        "filled": bool(filled),
        "n_fft": int(n_fft),
    }


def tip_reach_hz(rev_s: float, blade_length_m: float, carrier_hz: float, ocfg: OrderConfig | None = None) -> float:
    """How far from the body a rotor's lines can reach [Hz]: ``extent_range[1]`` times
    the tips' Doppler 2 (2 pi f L) / lambda plus ``tail_harmonics`` beta^(1/3)
    rotation harmonics (the thin-wire flash's Bessel tail)."""
    ocfg = ocfg or OrderConfig()
    beta = 4 * math.pi * blade_length_m * carrier_hz / SPEED_OF_LIGHT_MPS
    return (ocfg.extent_range[1] * beta + ocfg.tail_harmonics * beta ** (1 / 3)) * rev_s


def spectrum_problems(flight, *, ocfg: OrderConfig | None = None) -> list[tuple[str, str, str]]:
    """The spectrum's Doppler extent against the fastest plausible blade tips (module
    docstring); a drone's only, with a plausible carrier and PRF."""
    a = flight.attrs
    L = a.get("blade_length_m")
    if a.get("target") != "drone" or not L:
        return []
    ocfg, v_max = _limits(ocfg)
    prf, carrier, L = float(a["prf_hz"]), float(a["carrier_hz"]), float(L)
    ext = doppler_extent(flight.iq, prf, ocfg=ocfg)
    if ext is None:
        return []
    out = body_problems(flight, ext, ocfg=ocfg)
    f_max = min(ocfg.max_rev_s, v_max / (2 * math.pi * L))
    reach = tip_reach_hz(f_max, L, carrier, ocfg)
    if ext["extent_hz"] <= reach:
        return out
    e = ext["extent_hz"]
    shows = (
        f"the spectrum's lines fill ±PRF/2 = ±{e:.0f} Hz"
        if ext["filled"]
        else f"the spectrum's lines reach ±{e:.0f} Hz about the body"
    )
    return out + [
        (
            "prf_hz, carrier_hz",
            f"{shows}, but tips of blade_length_m {L:g} m at carrier_hz {_unit(carrier)} reach at most "
            f"±{reach:.0f} Hz for tip speeds <= {v_max:.0f} m/s (a {e / reach:.2g}x wider Doppler): check prf_hz, "
            "carrier_hz, blade_length_m",
            f"lines within the blade tips' Doppler (prf_hz {prf:g} Hz as declared)",
        )
    ]


def _track_doppler(flight, n_fft: int, ocfg: OrderConfig):
    """The track's Doppler -2 v / lambda over the recording, as :func:`body_problems`
    reads it: (its mean [Hz], the tolerance a body line may depart from it [Hz]: three
    bins of ``n_fft``, half the track's spread and ``track_speed_tol_mps``, the 64 times
    [s], the track's times and radial velocities); None without a usable track."""
    a = flight.attrs
    prf, lam = float(a["prf_hz"]), SPEED_OF_LIGHT_MPS / float(a["carrier_hz"])
    tt, v = np.asarray(flight.track_time_s, float), np.asarray(flight.track_radial_velocity_mps, float)
    if len(tt) == 0 or not np.all(np.isfinite(v)):
        return None
    t = np.linspace(0.0, len(flight.iq) / prf, 64)
    pred = -2 * np.interp(t, tt, v) / lam
    tol = 3 * prf / n_fft + (pred.max() - pred.min()) / 2 + 2 * ocfg.track_speed_tol_mps / lam
    return float(pred.mean()), float(tol), t, tt, v


def body_problems(flight, ext: dict | None, *, ocfg: OrderConfig | None = None) -> list[tuple[str, str, str]]:
    """The spectrum's body (``ext``, :func:`doppler_extent`) against the track's
    Doppler, where the track moves (module docstring)."""
    ocfg = ocfg or OrderConfig()
    if ext is None or ext["filled"]:
        return []
    a = flight.attrs
    prf = float(a["prf_hz"])
    track = _track_doppler(flight, ext["n_fft"], ocfg)
    if track is None:
        return []
    mean, tol, t, tt, v = track

    def wrap(x):
        return (x + prf / 2) % prf - prf / 2

    # the body is where the lines are centred or the strongest line: both must disagree
    offs = {}
    for key in ("centre_hz", "peak_hz"):
        offs[key] = min(abs(wrap(ext[key] - mean)), abs(wrap(ext[key] + mean)))
    key = min(offs, key=offs.get)
    obs, off = ext[key], offs[key]
    if abs(wrap(mean)) <= tol or off <= tol:
        return []
    v_mean = float(np.interp(t, tt, v).mean())
    return [
        (
            "prf_hz, carrier_hz",
            f"the body line stands at {obs:+.0f} Hz (the spectrum's strongest line and the centre of its lines "
            f"{ext['peak_hz']:+.0f}, {ext['centre_hz']:+.0f} Hz), but the track's radial "
            f"velocity {v_mean:+.2f} m/s puts it at {wrap(mean):+.0f} Hz at carrier_hz {_unit(float(a['carrier_hz']))}"
            f" and prf_hz {prf:g} (they differ by {off:.0f} Hz, more than the {tol:.0f} Hz the track's spread and "
            f"{ocfg.track_speed_tol_mps:g} m/s allow): check prf_hz, carrier_hz (or the track)",
            "the body line at the track's Doppler -2 v / lambda",
        )
    ]


def rotor_problems(
    flight, rev_s: list[float], *, source: str, ocfg: OrderConfig | None = None
) -> list[tuple[str, str, str]]:
    """The rotors' tip speed and Doppler at the rotation rates ``rev_s`` (the chosen
    one first, then the alternatives the lines allow) against physics and the
    spectrum's extent (module docstring): a problem only where no rate is plausible.

    Parameters
    ----------
    rev_s : list of float
        Mean rotation rates [rev/s]: the estimate's (then its order's alternatives) or
        the motor log's median.
    source : str
        Where the rates come from, for the message (``the radar's rotor comb``).
    """
    a = flight.attrs
    L = a.get("blade_length_m")
    rates = [float(r) for r in rev_s if r is not None and np.isfinite(r) and r > 0]
    if a.get("target") != "drone" or not L or not rates:
        return []
    ocfg, v_max = _limits(ocfg)
    prf, carrier, L = float(a["prf_hz"]), float(a["carrier_hz"]), float(L)
    ext = doppler_extent(flight.iq, prf, ocfg=ocfg)
    v_lo = TIP_SPEED_RANGE_MPS[0]
    why = []
    for f in rates:
        tip = 2 * math.pi * f * L
        reach = tip_reach_hz(f, L, carrier, ocfg)
        if not v_lo <= tip <= v_max:
            why.append(("tip", f, tip, reach))
        elif ext is not None and ext["extent_hz"] > reach:
            why.append(("beyond", f, tip, reach))
        else:
            return []
    kind, f, tip, reach = why[0]
    alts = (
        f" (and {', '.join(f'{r:.1f}' for r in rates[1:])} rev/s, the order's alternatives)" if len(rates) > 1 else ""
    )
    if kind == "tip":
        return [
            (
                "n_blades, blade_length_m, prf_hz",
                f"{source} turns at {f:.1f} rev/s{alts}: with blade_length_m {L:g} m the tips turn at {tip:.0f} m/s, "
                f"{'below' if tip < v_lo else 'above'} a drone's {v_lo:g}-{v_max:.0f} m/s: check n_blades, "
                "blade_length_m, prf_hz",
                f"blade tips at {v_lo:g}-{v_max:.0f} m/s",
            )
        ]
    return [
        (
            "carrier_hz, blade_length_m, n_blades",
            f"the spectrum's lines reach ±{ext['extent_hz']:.0f} Hz about the body, but {source} at {f:.1f} "
            f"rev/s{alts} puts tips of blade_length_m {L:g} m at carrier_hz {_unit(carrier)} at most ±{reach:.0f} Hz "
            "away: check carrier_hz, blade_length_m, n_blades",
            "lines within the blade tips' Doppler",
        )
    ]


def estimate_rates(est) -> list[float]:
    """The estimate's mean rotation rate and its order's alternatives [rev/s]."""
    v = est.valid
    if not est.ok or not v.any():
        return []
    o = (est.info or {}).get("order") or {}
    return [float(np.nanmedian(est.common_rev_s[v]))] + [float(x) for x in o.get("alternatives_rev_s", [])]


def blade_count_hint(est) -> str | None:
    """A hint naming ``n_blades`` where the rotor order's rates include one that another
    blade count reads the same comb as, else None.

    The lines' comb (spacing B f_lines, read with the declared B blades) gives f_lines
    B / B' with B' blades. Where the order check chose such a rate, or lists it as an
    alternative of an ambiguous order (within ``snap_rel``), for a B' of 2-4 (not B
    times a power of two: that ratio is a sub-harmonic's or unequal blades'), the
    declared blade count is in doubt.
    """
    o = (est.info or {}).get("order") or {}
    lines, chosen = float(o.get("lines_rev_s") or 0.0), float(o.get("chosen_rev_s") or 0.0)
    if lines <= 0 or chosen <= 0:
        return None
    B = int(est.n_blades)
    rates = [("chosen", chosen)] + (
        [("listed", float(a)) for a in o.get("alternatives_rev_s", [])] if o.get("ambiguous") else []
    )
    for how, r in rates:
        for b in range(2, 5):
            if (
                b != B
                and not math.log2(b / B).is_integer()
                and abs(math.log(r / (lines * B / b))) <= OrderConfig().snap_rel
            ):
                what = "chose" if how == "chosen" else f"lists beside {chosen:.1f} rev/s"
                return (
                    f"n_blades: the lines' comb read with {B} blades per rotor gives {lines:.1f} rev/s, read with "
                    f"{b} blades {r:.1f} rev/s, which the order check {what}: check n_blades"
                )
    return None


def flight_rates(flight) -> tuple[list[float], str | None]:
    """The flight's rotation rates [rev/s] and where they come from: the median of its
    motor log (the radar's estimate or a logged one), then the radar order's
    alternatives; ``([], None)`` without a motor log."""
    rpm = getattr(flight, "motors_rpm", None)
    if rpm is None or not np.size(rpm):
        return [], None
    r = np.asarray(rpm, np.float64)
    r = r[np.isfinite(r) & (r > 0)]
    if not r.size:
        return [], None
    radar = flight.attrs.get("motors_source") == "radar"
    alts = (flight.attrs.get("motors_radar") or {}).get("rotor_order_alternatives_rev_s", []) if radar else []
    return (
        [float(np.median(r)) / 60.0] + [float(a) for a in alts],
        "the radar's rotor comb" if radar else "the motor log",
    )


#: the declared-set-up errors :func:`setup_testability` asks the recording about: a
#: factor of 2 on a frequency or a length (a typo's size: x0.5, x2), and 2 <-> 3 blades
#: per rotor (the rotation rate then changes by 2/3 or 3/2)
TYPO_FACTOR = 2.0
BLADE_FACTOR = 1.5


def setup_testability(
    flight, rev_s: float | None, *, log_independent: bool, ocfg: OrderConfig | None = None
) -> dict[str, str]:
    """The declared fields this recording cannot test: ``{field: reason}`` (empty where
    every field is tested).

    A declared field is tested where some check this recording allows would see it
    off by a typo's size (:data:`TYPO_FACTOR`; for ``n_blades`` 2 <-> 3 blades,
    :data:`BLADE_FACTOR` on the rotation rate):

    - ``prf_hz`` (the frequency axis): by the body line against the track's Doppler
      -2 v / lambda where the track moves by more than the check's tolerance times
      :data:`TYPO_FACTOR` (:func:`body_problems`), or by a motor log that does not come
      from this recording (the lines must sit at n_blades times its rate). A hovering
      target whose rotor speeds come from its own lines scales the lines, the speeds
      and the tips' Doppler alike under a wrong PRF: nothing in the recording shows it.
    - ``carrier_hz`` (the wavelength): by the body against the track (as above), or by
      the tips: the lines' extent (:func:`doppler_extent`) against the tips' reach
      (:func:`tip_reach_hz`) at the rotor rate ``rev_s``. The extent bounds the tips
      from below only (lines need not reach them); the tips test a wavelength
      :data:`TYPO_FACTOR` off only where the lines reach past 1 / TYPO_FACTOR of the
      declared tips' reach.
    - ``n_blades``: by an independent motor log (the lines' spacing is n_blades times
      the rate), or by the tips where the lines reach past 1 / :data:`BLADE_FACTOR` of
      their reach (the rate, hence the tips, scales by 2/3 with 3 blades declared for 2).
    - ``blade_length_m``: by the tips only, as ``carrier_hz``'s.

    Besides the declared fields, ``rotor_order`` where the rotor speeds come from the
    radar and its order check marks the order ambiguous (``motors_radar``): the
    diagnosis took one of the rates the lines allow.

    Parameters
    ----------
    flight : Flight
        A drone recording (anything else: ``{}``).
    rev_s : float or None
        The rotors' mean rotation rate [rev/s] the diagnosis uses (the motor log's,
        estimated from the radar or logged); None where there is none.
    log_independent : bool
        The rate comes from a motor log that is not this recording's own estimate.
    """
    a = flight.attrs
    L = a.get("blade_length_m")
    if a.get("target") != "drone" or not L:
        return {}
    ocfg = ocfg or OrderConfig()
    prf, carrier, L = float(a["prf_hz"]), float(a["carrier_hz"]), float(L)
    ext = doppler_extent(flight.iq, prf, ocfg=ocfg)
    # the body against the track: how far the track's mean Doppler lies from 0 Hz, in
    # units of the check's tolerance (as body_problems reads it)
    moving, body_note = False, "no track"
    track = _track_doppler(flight, ext["n_fft"] if ext is not None else 4096, ocfg)
    if track is not None:
        mean, tol = abs(track[0]), track[1]
        moving = mean * (1 - 1 / TYPO_FACTOR) > tol
        body_note = (
            f"a frequency axis or wavelength {TYPO_FACTOR:g}x off moves the body line by "
            f"{mean * (1 - 1 / TYPO_FACTOR):.0f} Hz from the track's Doppler ({mean:.0f} Hz), within the {tol:.0f} Hz "
            "its check allows"
        )
    # the lines' extent against the tips' reach at the rate: the tips are seen down to
    # reach_share of their declared reach (lines need not reach the tips: from below only)
    reach_share = None
    if rev_s is not None and np.isfinite(rev_s) and rev_s > 0 and ext is not None and not ext["filled"]:
        reach_share = ext["extent_hz"] / tip_reach_hz(float(rev_s), L, carrier, ocfg)

    def tips_see(k: float) -> bool:
        """The tips would show their Doppler ``k`` x smaller (the lines past it)."""
        return reach_share is not None and reach_share > 1 / k

    if reach_share is None:
        tips_note = "no rotor rate or no lines to compare with the tips' Doppler"
    else:
        tips_note = (
            f"the lines end at ±{ext['extent_hz']:.0f} Hz, {reach_share:.0%} of the reach of the declared tips "
            f"({2 * math.pi * rev_s * L:.0f} m/s at {rev_s:.1f} rev/s)"
        )
    out = {}
    if not moving and not log_independent:
        out["prf_hz"] = (
            f"{body_note} and the rotor speeds come from this recording's own lines: a PRF "
            f"{TYPO_FACTOR:g}x off scales the lines, the speeds and the tips' Doppler alike"
        )
    if not moving and not tips_see(TYPO_FACTOR):
        out["carrier_hz"] = f"{body_note}, and {tips_note}: a carrier {TYPO_FACTOR:g}x off explains them alike"
    if not log_independent and not tips_see(BLADE_FACTOR):
        out["n_blades"] = (
            f"the rotor rate is the lines' spacing over n_blades (this recording's own comb), and {tips_note}: "
            "2 and 3 blades explain them alike"
        )
    radar = a.get("motors_radar") if a.get("motors_source") == "radar" else None
    order = (radar or {}).get("rotor_order") or {}
    if order.get("ambiguous") and rev_s is not None:
        alts = (radar or {}).get("rotor_order_alternatives_rev_s") or order.get("alternatives_rev_s") or []
        out["rotor_order"] = (
            f"the radar's rotor comb reads {rev_s:.1f} rev/s"
            + (f" or {', '.join(f'{float(x):.1f}' for x in alts)} rev/s" if alts else "")
            + f" (the order check marks it ambiguous): the diagnosis took {rev_s:.1f} rev/s; a motor log "
            "(--motor-log) or lines that reach the tips would tell"
        )
    if not tips_see(TYPO_FACTOR):
        out["blade_length_m"] = (
            f"{tips_note}: blades {TYPO_FACTOR:g}x shorter explain them alike (and longer ones always do: the "
            "lines bound the tips from below only)"
        )
    return out


def recording_problems(flight, *, rotors: bool = True, ocfg: OrderConfig | None = None) -> list[tuple[str, str, str]]:
    """Every check of this module on ``flight``: the spectrum's extent, and with
    ``rotors`` the tips at the rates of its motor log (where it has one)."""
    out = spectrum_problems(flight, ocfg=ocfg)
    if rotors and not out:
        rates, source = flight_rates(flight)
        if rates:
            out += rotor_problems(flight, rates, source=source, ocfg=ocfg)
    return out
