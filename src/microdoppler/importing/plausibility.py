"""Is a recording's declared set-up physically plausible? Checked by ``microdoppler
import`` before a store is written.

Each check compares a declared parameter with what a radar that records drones can be
and with what the recording itself holds, and is conservative: it refuses only a
set-up that no such radar has (the legitimate recordings of every supported kind pass).

- the carrier lies in :data:`CARRIER_RANGE_HZ` (a carrier of a few Hz is GHz typed as
  Hz, one of a few thousand MHz typed as Hz);
- the PRF (slow-time sample rate) lies in :data:`PRF_RANGE_HZ`;
- the recording lasts at least one CPI of the pipeline
  (:class:`~microdoppler.spectra.spectrogram.SpectrogramSettings`: the power of two
  nearest 0.56 s x PRF pulses), since nothing shorter gives one spectrum;
- a drone's blade tips, turning at the slowest plausible tip speed
  (:data:`TIP_SPEED_RANGE_MPS`), reach a Doppler 2 v / lambda that folds past ±PRF / 2
  at most :data:`MAX_TIP_FOLDS` times (real set-ups at 24 GHz with a low PRF fold a few
  times; tens of folds means the carrier or the PRF is off by a factor).
"""

from __future__ import annotations


from ..errors import InputError

#: a radar's carrier [Hz]: 100 MHz (VHF) to 300 GHz (the top of the mm-wave band)
CARRIER_RANGE_HZ = (100e6, 300e9)
#: a pulse repetition frequency or slow-time sample rate [Hz]
PRF_RANGE_HZ = (100.0, 2e6)
#: plausible blade-tip speeds of a drone's rotors [m/s]
TIP_SPEED_RANGE_MPS = (30.0, 250.0)
#: folds past ±PRF/2 of the slowest plausible tips' Doppler that still pass
MAX_TIP_FOLDS = 20.0
#: the attribute a ``--force`` import stores its warnings in
ATTR = "plausibility_warnings"
SPEED_OF_LIGHT_MPS = 299_792_458.0


def _unit(hz: float) -> str:
    for f, u in ((1e9, "GHz"), (1e6, "MHz"), (1e3, "kHz")):
        if hz >= f:
            return f"{hz / f:.4g} {u}"
    return f"{hz:.4g} Hz"


def setup_problems(
    *, prf_hz: float, carrier_hz: float, n_pulses: int, target: str | None = None, blade_length_m: float | None = None
) -> list[tuple[str, str, str]]:
    """The declared set-up's contradictions: ``(field, what the recording shows,
    expected)`` each; empty where the set-up is plausible.

    Parameters
    ----------
    prf_hz, carrier_hz : float
        The declared PRF (slow-time sample rate) and carrier [Hz].
    n_pulses : int
        Slow-time samples in the recording.
    target : str, optional
        ``drone`` enables the blade-tip check.
    blade_length_m : float, optional
        Declared blade length, hub to tip [m] (only reported with the tips' Doppler).
    """
    from ..spectra.spectrogram import SpectrogramSettings

    out = []
    lo, hi = CARRIER_RANGE_HZ
    carrier_ok = lo <= carrier_hz <= hi
    if not carrier_ok:
        guess = ""
        for f, u in ((1e9, "GHz"), (1e6, "MHz")):
            if lo <= carrier_hz * f <= hi:
                guess = f": looks like {u} typed as Hz ({carrier_hz:g} {u} = {carrier_hz * f:.4g} Hz)"
                break
        out.append(("carrier_hz", f"is {carrier_hz:g} Hz{guess}", f"a radar carrier in {_unit(lo)}-{_unit(hi)}, in Hz"))
    lo, hi = PRF_RANGE_HZ
    prf_ok = lo <= prf_hz <= hi
    if not prf_ok:
        guess = (
            f": looks like kHz typed as Hz ({prf_hz:g} kHz = {prf_hz * 1e3:g} Hz)" if lo <= prf_hz * 1e3 <= hi else ""
        )
        out.append(("prf_hz", f"is {prf_hz:g} Hz{guess}", f"a PRF or slow-time sample rate in {_unit(lo)}-{_unit(hi)}"))
    if prf_ok and carrier_ok:
        n_fft = SpectrogramSettings().resolve(prf_hz, carrier_hz).n_fft
        if n_pulses < n_fft:
            out.append(
                (
                    "duration",
                    f"the recording holds {n_pulses} pulses = {n_pulses / prf_hz:.3g} s at prf_hz "
                    f"{prf_hz:g}, shorter than one CPI",
                    f"at least one CPI of the pipeline, {n_fft} pulses = {n_fft / prf_hz:.3g} s",
                )
            )
        if target == "drone":
            lam = SPEED_OF_LIGHT_MPS / carrier_hz
            tip_hz = 2 * TIP_SPEED_RANGE_MPS[0] / lam
            folds = tip_hz / (prf_hz / 2)
            if folds > MAX_TIP_FOLDS:
                length = f" of the {blade_length_m:g} m blades" if blade_length_m else ""
                out.append(
                    (
                        "prf_hz",
                        f"is {prf_hz:g} Hz with carrier_hz {carrier_hz:g}: even the slowest plausible "
                        f"tips{length} ({TIP_SPEED_RANGE_MPS[0]:g} m/s) reach {tip_hz:.0f} Hz, {folds:.0f} times "
                        "±PRF/2 (check prf_hz and carrier_hz)",
                        f"blade tips' Doppler within {MAX_TIP_FOLDS:g} x PRF/2",
                    )
                )
    return out


def check_setup(source, attrs: dict, n_pulses: int, *, force: bool = False) -> list[str]:
    """Check a flight's declared set-up (:func:`setup_problems`) before it is written.

    Returns the warnings (one line each, ``field: problem``) where ``force``; empty
    where the set-up is plausible.

    Raises
    ------
    InputError
        One line naming ``source``, the fields and what the recording shows, when the
        set-up is implausible and not ``force``.
    """
    probs = setup_problems(
        prf_hz=float(attrs["prf_hz"]),
        carrier_hz=float(attrs["carrier_hz"]),
        n_pulses=n_pulses,
        target=attrs.get("target"),
        blade_length_m=attrs.get("blade_length_m"),
    )
    return settle(source, probs, force=force)


def settle(source, probs: list[tuple[str, str, str]], *, force: bool = False) -> list[str]:
    """Refuse the contradictions ``probs`` (``(field, what the recording shows,
    expected)`` each) in one line, or with ``force`` return them as warnings (one line
    each, ``field: problem (expected ...)``); empty where there are none.

    Raises
    ------
    InputError
        Naming ``source``, every field and what the recording shows, unless ``force``.
    """
    if not probs:
        return []
    if not force:
        fields = ", ".join(dict.fromkeys(f.strip() for fs, _, _ in probs for f in fs.split(",")))
        first = probs[0]
        more = "".join(f"; {f}: {p}" for f, p, _ in probs[1:])
        raise InputError(
            source, fields, f"{first[1]}{more}", f"{first[2]}; --force imports it anyway, with the warning stored"
        )
    return [f"{f}: {p} (expected {e})" for f, p, e in probs]


def mark(flight, warnings: list[str]):
    """``flight`` with ``warnings`` added to its ``plausibility_warnings`` attribute."""
    if warnings:
        flight.attrs[ATTR] = list(flight.attrs.get(ATTR, [])) + list(warnings)
    return flight
