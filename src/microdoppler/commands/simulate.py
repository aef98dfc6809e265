"""``microdoppler simulate --out STORE.zarr``: write a synthetic flight-zarr/1 store.

The echo is eq. (2) of the paper (thin-wire blades of eq. 1 summed over motors and
blades, body return, alpha envelope; ``--blade-scattering dielectric`` scales the
blade echo for plastic blades, ``--blade-amplitudes`` gives blades their own scattering
amplitudes) from :func:`microdoppler.synthesis.model.synthesize`,
driven by constant per-motor speeds (``--motor-hz``) or a motor log (``--motor-log``,
resampled to the PRF with ``--variant``), along a constant-velocity track or a track
CSV (``time_s``, ``range_m``).

SNR (``--snr-db``): body power per pulse over noise power per pulse,
``SNR = S_body**2 / sigma**2`` (the body amplitude is S_body; complex white Gaussian
noise of total power sigma**2 per pulse). A spectrogram line gains the coherent
integration of one CPI on top (about 10 log10(4096) - 1.5 dB for a Blackman-Harris
window, ~34.6 dB). Without ``--snr-db`` the store is noise-free.
"""

from __future__ import annotations

import re
import sys
import time
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.flightzarr import Flight, write_flight
from ..io.outputs import check_output
from ..io.tracks import read_track_table
from ..io.motorlog import read_motor_log, read_motor_store
from ..synthesis.radar import Radar
from ..rotors.sampling import VARIANTS, SamplingConfig, resample
from ..synthesis.model import BLADE_SCATTERING, Scaling, SynthesisConfig, Track, add_noise, synthesize
from . import add_overwrite, finite, non_negative, positive, positive_int, seed

SRC = "simulate"
PROGRESS_MIN_PULSES = 1 << 21  # report progress on stderr for longer runs
MAX_PULSES = 1 << 30  # 8 GiB of complex64 I/Q (about 41 h at 7.3 kHz)
MAX_MOTOR_HZ = 1000.0  # 60000 rpm, the format's bound on logged speeds
MAX_AMPLITUDE = 1e12  # keeps every sample finite in complex64


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "simulate",
        help="simulate a drone flight (eq. 1/2) into a flight-zarr/1 store",
        description=__doc__.split("\n\n")[1] + " SNR = body power per pulse / noise power per pulse.",
    )
    p.add_argument("--out", required=True, help="output flight-zarr/1 store (directory)")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--motor-hz", help="constant per-motor speeds [rev/s], comma-separated, e.g. 85,90,95,100")
    src.add_argument(
        "--motor-log",
        help="motor log: .ulg, .csv (time_s + one column per motor, rpm) or a Zarr "
        "store with motors/time_s, motors/rpm",
    )
    p.add_argument("--variant", choices=VARIANTS, default="sub_cpi", help="sampling of the motor log (default sub_cpi)")
    p.add_argument("--window-pulses", type=positive_int, default=2500, help="sub_cpi rolling-average length [pulses]")
    p.add_argument("--typical-hz", type=positive, default=80.0, help="fixed_speeds: typical rotor speed [rev/s]")
    p.add_argument("--range-m", type=positive, default=500.0, help="initial range [m] (default 500)")
    p.add_argument(
        "--radial-velocity-mps",
        type=finite,
        default=-5.0,
        help="constant dR/dt [m/s], negative = approaching (default -5)",
    )
    p.add_argument("--track", help="track CSV with columns time_s, range_m (replaces --range-m/--radial-velocity-mps)")
    p.add_argument("--prf-hz", type=positive, default=7300.0, help="pulse repetition frequency [Hz] (default 7300)")
    p.add_argument("--carrier-hz", type=positive, default=1.35e9, help="carrier frequency [Hz] (default 1.35e9)")
    p.add_argument("--blade-length-m", type=positive, default=0.19, help="blade length, hub to tip [m] (default 0.19)")
    p.add_argument("--n-blades", type=positive_int, default=2, help="blades per rotor (default 2)")
    p.add_argument(
        "--blade-scattering",
        choices=BLADE_SCATTERING,
        default="thin_wire",
        help="blade echo model: thin_wire (eq. 1, default) or dielectric (plastic blades: echo ~ "
        "(L/lambda)^2 below eq. 1, normalised to the 0.19 m blade at 1.35 GHz)",
    )
    p.add_argument(
        "--blade-amplitudes",
        default=None,
        help="each blade's scattering amplitude relative to eq. 1 (>= 0), comma-separated, one per "
        "blade for every motor (e.g. 1,0.5: the second blade scatters half as much; unequal "
        "blades add lines at odd multiples of the rotation rate), or a row per motor separated "
        "by ';' (e.g. '1,1;1,0.5;1,1;1,1'); default all 1",
    )
    p.add_argument("--drone-model", default="inspire2", help="drone_model attribute (default inspire2)")
    p.add_argument(
        "--duration-s",
        type=positive,
        default=None,
        help="flight duration [s] (default: the motor log's or track's span, else 10 s)",
    )
    p.add_argument("--alpha", type=non_negative, default=0.0, help="sideband envelope alpha_s [s = 1/Hz] (default 0)")
    p.add_argument("--s-body", type=non_negative, default=1.0, help="body amplitude S_body (default 1)")
    p.add_argument("--s-blade", type=non_negative, default=1.0, help="blade amplitude scale S_blade (default 1)")
    p.add_argument("--seed", type=seed, default=0, help="seed of rotor angles, fixed_speeds draw and noise")
    p.add_argument(
        "--snr-db",
        type=finite,
        default=None,
        help="body power per pulse / noise power per pulse [dB]; noise-free if omitted",
    )
    p.add_argument("--flight-id", default=None, help="flight_id attribute (default: the store's name)")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")
    add_overwrite(p)
    p.set_defaults(func=run)


def _check(ok: bool, field: str, value, expected: str) -> None:
    if not ok:
        raise InputError(SRC, field, f"is {value}", expected)


def read_track_csv(path) -> Track:
    """Track CSV (``time_s``, ``range_m``) -> :class:`Track` starting at 0 s; bad files
    raise InputError (:func:`microdoppler.io.tracks.read_track_table`)."""
    t, r = read_track_table(path)
    return Track(t - t[0], r)


def parse_blade_amplitudes(text: str | None, n_blades: int, n_motors: int) -> list | None:
    """``--blade-amplitudes`` -> a list [n_blades] (every motor) or [n_motors][n_blades]
    of amplitudes >= 0; None when not given."""
    if text is None:
        return None
    expected = (
        f"{n_blades} comma-separated amplitudes >= 0 (one per blade), or {n_motors} such rows "
        f"separated by ';' (one per motor)"
    )
    try:
        rows = [[float(v) for v in row.split(",")] for row in text.split(";")]
    except ValueError:
        raise InputError(SRC, "--blade-amplitudes", f"is {text!r}", expected) from None
    ok = (
        all(len(r) == n_blades for r in rows)
        and len(rows) in (1, n_motors)
        and all(np.isfinite(v) and v >= 0 for r in rows for v in r)
    )
    _check(ok, "--blade-amplitudes", repr(text), expected)
    return rows[0] if len(rows) == 1 else rows


def _load_log(path):
    p = Path(path)
    if p.is_dir():
        return read_motor_store(p)
    return read_motor_log(p)


def run(args) -> int:
    check_output(args.out, kind="store", overwrite=args.overwrite)
    _check(args.blade_length_m < 5, "--blade-length-m", args.blade_length_m, "in (0, 5) m")
    _check(args.s_body <= MAX_AMPLITUDE, "--s-body", args.s_body, f"<= {MAX_AMPLITUDE:g}")
    _check(args.s_blade <= MAX_AMPLITUDE, "--s-blade", args.s_blade, f"<= {MAX_AMPLITUDE:g}")
    if args.snr_db is not None:
        _check(args.s_body > 0, "--s-body", args.s_body, "> 0 when --snr-db is given (SNR is relative to the body)")
        _check(-100 <= args.snr_db <= 300, "--snr-db", args.snr_db, "in [-100, 300] dB")
    radar = Radar(prf_hz=args.prf_hz, carrier_hz=args.carrier_hz)
    flight_id = args.flight_id or re.sub(r"[^A-Za-z0-9_.-]", "_", Path(args.out).name.removesuffix(".zarr"))

    log = None
    if args.motor_log:
        log = _load_log(args.motor_log)
        log = log.shifted(-float(log.time_s[0]))
    else:
        try:
            motor_hz = [float(v) for v in args.motor_hz.split(",")]
        except ValueError:
            raise InputError(SRC, "--motor-hz", f"is {args.motor_hz!r}", "comma-separated speeds [rev/s]") from None
        top = min(MAX_MOTOR_HZ, args.prf_hz)
        _check(
            len(motor_hz) >= 1 and all(np.isfinite(v) and 0 <= v <= top for v in motor_hz),
            "--motor-hz",
            args.motor_hz,
            f"speeds in [0, {top:g}] rev/s",
        )
    track = read_track_csv(args.track) if args.track else None

    duration = args.duration_s
    if duration is None:
        duration = log.duration_s if log is not None else (float(track.time_s[-1]) if track is not None else 10.0)
    if log is not None and duration > log.duration_s + 1.0 / args.prf_hz:
        raise InputError(
            SRC,
            "--duration-s",
            f"is {duration:g} s, longer than the motor log's {log.duration_s:.2f} s",
            "a duration within the log (speeds after its end are unknown)",
        )
    n_pulses = int(round(duration * args.prf_hz))
    _check(
        2 <= n_pulses <= MAX_PULSES,
        "--duration-s",
        duration,
        f"2 to {MAX_PULSES} pulses at {args.prf_hz:g} Hz (got {n_pulses})",
    )
    if track is None:
        end_range = args.range_m + args.radial_velocity_mps * duration
        _check(
            args.range_m > 0 and end_range > 0,
            "--range-m/--radial-velocity-mps",
            f"{args.range_m} m at {args.radial_velocity_mps} m/s (range {end_range:.1f} m at the end)",
            "a range > 0 m over the whole flight",
        )
        track = Track.constant_velocity(args.range_m, args.radial_velocity_mps, duration)
    elif track.time_s[-1] < (n_pulses - 1) / args.prf_hz:
        raise InputError(
            args.track, "time_s", f"ends at {track.time_s[-1]:g} s", f"a track covering the flight's {duration:g} s"
        )

    if log is not None:
        cfg = SamplingConfig(n_fft=radar.n_fft, window_pulses=args.window_pulses)
        rev_s = resample(args.variant, log, n_pulses, args.prf_hz, typical_hz=args.typical_hz, seed=args.seed, cfg=cfg)
        motors_time_s, motors_rpm = log.time_s, log.rpm
    else:
        rev_s = np.broadcast_to(np.asarray(motor_hz, np.float32), (n_pulses, len(motor_hz)))
        motors_time_s = np.array([0.0, duration])
        motors_rpm = np.tile(np.asarray(motor_hz, np.float32) * 60, (2, 1))
    n_motors = rev_s.shape[1]

    t0 = time.monotonic()
    last = [0.0]

    def progress(done, total):
        now = time.monotonic()
        if args.quiet or total < PROGRESS_MIN_PULSES or (now - last[0] < 2.0 and done < total):
            return
        last[0] = now
        rate = done / max(now - t0, 1e-9)
        print(
            f"simulate: {done / total:6.1%} ({done / 1e6:.1f} of {total / 1e6:.1f} M pulses, "
            f"{rate / 1e6:.1f} M pulses/s)",
            file=sys.stderr,
            flush=True,
        )

    scaling = Scaling(s_body=args.s_body, s_blade=args.s_blade, alpha_s=args.alpha)
    amplitudes = parse_blade_amplitudes(args.blade_amplitudes, args.n_blades, n_motors)
    config = SynthesisConfig.of(
        prf_hz=args.prf_hz,
        wavelength_m=radar.wavelength_m,
        n_blades=args.n_blades,
        blade_length_m=args.blade_length_m,
        scaling=scaling,
        blade_amplitudes=amplitudes,
        scattering=args.blade_scattering,
    )
    iq = synthesize(config, track, rev_s, seed=args.seed, progress=progress)
    noise_power = None
    if args.snr_db is not None:
        noise_power = args.s_body**2 / 10 ** (args.snr_db / 10)
        noise_seed = int(np.random.SeedSequence([args.seed, 1]).generate_state(1)[0])
        add_noise(iq, noise_power, noise_seed)

    t_track = np.arange(0.0, duration, 0.1)
    if len(t_track) < 2 or t_track[-1] < duration:
        t_track = np.append(t_track, duration)
    sim_log = (
        {"motor_log": str(args.motor_log), "variant": args.variant}
        if log is not None
        else {"motor_hz": [float(v) for v in motor_hz]}
    )
    attrs = {
        "schema": "flight-zarr/1",
        "flight_id": flight_id,
        "target": "drone",
        "radar_id": "simulated",
        "prf_hz": float(args.prf_hz),
        "carrier_hz": float(args.carrier_hz),
        "drone_model": args.drone_model,
        "n_motors": int(n_motors),
        "n_blades": int(args.n_blades),
        "blade_length_m": float(args.blade_length_m),
        "simulation": {
            "alpha_s": args.alpha,
            "s_body": args.s_body,
            "s_blade": args.s_blade,
            "blade_scattering": args.blade_scattering,
            "seed": args.seed,
            **({"blade_amplitudes": amplitudes} if amplitudes is not None else {}),
            "snr_db": args.snr_db,
            "snr_definition": "body power per pulse / noise power per pulse",
            "noise_power": noise_power,
            **sim_log,
        },
    }
    flight = Flight(
        attrs=attrs,
        iq=iq,
        track_time_s=t_track,
        track_range_m=track.range_at(t_track),
        track_radial_velocity_mps=track.radial_velocity_at(t_track),
        motors_time_s=motors_time_s if n_motors == motors_rpm.shape[1] else None,
        motors_rpm=motors_rpm if n_motors == motors_rpm.shape[1] else None,
    )
    write_flight(args.out, flight)
    if not args.quiet:
        print(
            f"{args.out}: {n_pulses} pulses ({duration:.2f} s), {n_motors} motors, {time.monotonic() - t0:.1f} s",
            file=sys.stderr,
        )
    return 0
