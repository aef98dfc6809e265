"""``microdoppler import RECORDING --out STORE.zarr``: a recording -> flight-zarr/1.

Reads SigMF (``.sigmf-meta`` + ``.sigmf-data``), MATLAB ``.mat`` (v5 and v7.3) and
NumPy ``.npy``/``.npz`` recordings of one target's slow-time I/Q (one sample per
pulse). Radar parameters come from the file's own metadata where it has them
(SigMF ``core:sample_rate`` -> prf_hz, ``captures[0].core:frequency`` -> carrier_hz),
else from a YAML sidecar (``--sidecar``) or options; an option beats the sidecar,
which beats the file, and an option that contradicts the file's metadata wins with a
warning. The track is a CSV (``--track``: time_s, range_m[, radial_velocity_mps];
radial velocity from the gradient otherwise) or a constant range (``--range-m``,
a staring recording: radial velocity 0). The receiver's I/Q balance is measured
(image-rejection ratio: from ``--background``, else from a target-free
``--noise-segment-s`` of the recording, else from the body line when it lies well
away from 0 Hz, else "not measurable" -- a hovering rotor's spectrum is
mirror-symmetric by nature; and the Doppler sign against the track); a doubtful one
is warned about on stderr; both go into the store's ``import`` attribute. The declared
set-up is checked before anything is written (carrier and PRF in a radar's range, at
least one CPI of recording, a drone's blade tips not folding far past ±PRF/2), and a
drone's against the recording itself (the spectrum's Doppler extent against the
fastest plausible tips, the body line against the track's Doppler, the tips' speed at
the estimated or logged rotor speeds: :mod:`microdoppler.rotors.plausibility`): an
implausible one is refused naming the suspect fields, or written with ``--force`` and
the warning stored in the ``plausibility_warnings`` attribute.

Raw FMCW data (``.npy``/``.npz``/``.mat``: a cube [chirps, samples] or [chirps,
samples, channels], real or complex) is read when its chirp parameters are given
(``--chirp-rate-hz``, ``--bandwidth-hz`` (swept over the sampled part of a chirp),
``--sample-rate-hz`` (fast time) and ``--carrier-hz`` (the sweep's centre), from the
file's variables, a sidecar or these options): range profiles per chirp, the
static part of each range bin removed per CPI (``--cpi-chirps``), the target's bin
followed from CPI to CPI (the most moving-target power, at most 2 bins per CPI; or
``--range-bin``), and that bin's slow time written at the chirp rate, with the track
from the bin's range (see :mod:`microdoppler.importing.fmcw`).

``--batch TABLE.csv --out FOLDER`` converts a campaign: one row per recording,
column ``file`` (relative to the table) plus optional columns named like the sidecar
keys (``prf_hz``, ``carrier_hz``, ``radar_id``, ``target``, ``drone_model``,
``n_motors``, ``n_blades``, ``blade_length_m``, ``range_m``, ``flight_id``,
``n_samples``, ``track``, ``layout``, ``variable``, and ``sidecar``) and the files
that ``--background`` and ``--motor-log`` name for one recording (columns
``background``, ``motor_log``, ``motor_log_unit``); a row's cell beats the
command-line option, and ``--estimate-motors`` applies to the drone rows without a
``motor_log``. FOLDER then holds ``<flight_id>.zarr`` stores only,
ready for ``measurements.source: directory``. It is written atomically: a bad row
leaves nothing behind.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pandas as pd

from ..errors import InputError
from ..importing import import_recording
from ..io.flightzarr import write_flight
from ..io.motorlog import UNIT_TO_RPM, read_motor_log
from ..io.outputs import atomic_dir, check_output, commit_folder, is_tool_store
from ..io.recordings import (
    BEAT_SIGNS,
    EXTRA_KEYS,
    LAYOUTS,
    OPTION,
    PARAM_TYPES,
    SIDECAR_KEYS,
    convert,
    default_flight_id_for,
    parse_noise_segment,
    read_sidecar,
)
from . import add_overwrite, positive, positive_int

#: parameters that have a command-line option (n_samples is a sidecar/table key only)
OPTION_KEYS = (
    "prf_hz",
    "carrier_hz",
    "radar_id",
    "target",
    "drone_model",
    "n_motors",
    "n_blades",
    "blade_length_m",
    "range_m",
    "flight_id",
    "chirp_rate_hz",
    "bandwidth_hz",
    "sample_rate_hz",
    "range_bin",
    "cpi_chirps",
    "beat_sign",
    "noise_segment_s",
)
#: batch-table columns that name a file (relative to the table) besides ``track``
ROW_FILES = ("file", "sidecar", "background", "motor_log")
TABLE_COLUMNS = (*ROW_FILES, "motor_log_unit", *SIDECAR_KEYS)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "import",
        help="convert a recording (SigMF, .mat, .npy/.npz) into a flight-zarr/1 store",
        description=__doc__.split("\n\n")[1],
    )
    p.add_argument(
        "recording",
        nargs="?",
        help="the recording: X.sigmf-meta (or .sigmf-data), X.mat, X.npy, X.npz (slow-time I/Q, or an FMCW cube)",
    )
    p.add_argument(
        "--batch",
        default=None,
        metavar="TABLE.csv",
        help="convert every recording of a table (column file + optional parameter columns) into "
        "--out FOLDER/<flight_id>.zarr",
    )
    p.add_argument("--out", required=True, help="output flight-zarr/1 store (a folder of stores with --batch)")
    p.add_argument(
        "--sidecar",
        default=None,
        help="YAML file with the parameters the recording lacks (keys: " + ", ".join(SIDECAR_KEYS) + ")",
    )
    p.add_argument(
        "--layout",
        choices=LAYOUTS,
        default=None,
        help="how the file stores I/Q when it does not say: one complex array, or two real "
        "columns I, Q (default: from the file)",
    )
    p.add_argument(
        "--variable",
        default=None,
        help=".mat/.npz: the array holding the I/Q (NAME), or the I and Q arrays (NAME_I,NAME_Q)",
    )
    p.add_argument("--prf-hz", type=positive, default=None, help="pulse repetition frequency [Hz]")
    p.add_argument("--carrier-hz", type=positive, default=None, help="carrier frequency [Hz]")
    p.add_argument("--radar-id", default=None, help="which radar recorded it")
    p.add_argument("--target", choices=("drone", "bird", "none"), default=None, help="what was recorded")
    p.add_argument("--drone-model", default=None, help="drones: drone_model attribute, e.g. inspire2")
    p.add_argument("--n-motors", type=positive_int, default=None, help="drones: number of motors")
    p.add_argument("--n-blades", type=positive_int, default=None, help="drones: blades per rotor")
    p.add_argument("--blade-length-m", type=positive, default=None, help="drones: blade length, hub to tip [m]")
    trk = p.add_mutually_exclusive_group()
    trk.add_argument(
        "--range-m",
        type=positive,
        default=None,
        help="constant range [m] of a staring recording without a track (radial velocity 0)",
    )
    trk.add_argument("--track", default=None, help="track CSV: time_s, range_m[, radial_velocity_mps]")
    p.add_argument(
        "--flight-id",
        default=None,
        help="flight_id attribute (default: the store's name; with --batch, the file's name)",
    )
    p.add_argument(
        "--noise-segment-s",
        default=None,
        metavar="START:END",
        help="a stretch of the recording [s] that holds no target: the I/Q balance is measured there "
        "(when there is no --background)",
    )
    fm = p.add_argument_group("FMCW cubes (.npy/.npz/.mat [chirps, samples(, channels)])")
    fm.add_argument(
        "--chirp-rate-hz",
        type=positive,
        default=None,
        help="chirps per second: the slow-time rate, stored as prf_hz [Hz]",
    )
    fm.add_argument(
        "--bandwidth-hz",
        type=positive,
        default=None,
        help="frequency swept over a chirp's sampled part [Hz] (range bin = c / 2B)",
    )
    fm.add_argument("--sample-rate-hz", type=positive, default=None, help="fast-time (ADC) sample rate [Hz]")
    fm.add_argument(
        "--range-bin",
        type=positive_int,
        default=None,
        help="take this range bin (0 = DC) instead of following the moving target",
    )
    fm.add_argument(
        "--cpi-chirps",
        type=positive_int,
        default=None,
        help="chirps per CPI for the static removal and the bin tracking (default: a power of two within 50 ms)",
    )
    fm.add_argument(
        "--beat-sign",
        choices=BEAT_SIGNS,
        default=None,
        help="targets at positive beat frequencies (transmitted x conj(received), a real mixer; the "
        "default) or negative ones (received x conj(transmitted))",
    )
    p.add_argument(
        "--background",
        default=None,
        help="a target-free recording of the same cells (same format and layout), stored as "
        "background/iq for injecting twins and for the diagnosis' floor tests",
    )
    p.add_argument(
        "--motor-log",
        default=None,
        help="drones: the flight's motor log (.ulg, or .csv with time_s on the radar clock and one "
        "column per motor), stored as motors/time_s, motors/rpm",
    )
    p.add_argument(
        "--motor-log-unit",
        choices=tuple(UNIT_TO_RPM),
        default="rpm",
        help="unit of the CSV motor columns (default rpm)",
    )
    p.add_argument(
        "--estimate-motors",
        action="store_true",
        help="drones without --motor-log: estimate each rotor's speed over time from the HERM lines "
        "and store it as the motor log (motors_source: radar, with its uncertainty); a flight "
        "with no visible sideband pair gets no estimate, and the reason is printed",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="write the store even where the declared set-up looks implausible (a carrier or PRF outside "
        "a radar's range, a recording shorter than one CPI, blade tips folding far past ±PRF/2, a "
        "spectrum, body line or rotor speed that contradicts the declared PRF, carrier, blade count "
        "or blade length); "
        "the warning is stored as the plausibility_warnings attribute and repeated by validate and "
        "diagnose",
    )
    p.add_argument("--quiet", action="store_true", help="no summary line on stderr (warnings are still shown)")
    add_overwrite(p)
    p.set_defaults(func=run)


def _options(args) -> dict:
    out = {}
    for k in OPTION_KEYS + ("track",):
        v = getattr(args, k)
        if v is not None:
            if k == "noise_segment_s":
                v = parse_noise_segment(v, OPTION[k], "value")
            out[k] = (v, OPTION[k])
    return out


def _summary(path, out, flight, warns) -> dict:
    imp = flight.attrs["import"]
    return {
        "path": path,
        "out": out,
        "n": len(flight.iq),
        "duration_s": flight.duration_s,
        "format": imp["format"],
        "layout": imp["layout"],
        "irr": imp.get("image_rejection_db"),
        "irr_from": imp.get("image_rejection_from"),
        "fmcw": imp.get("fmcw"),
        "range_m": (float(flight.track_range_m.min()), float(flight.track_range_m.max())),
        "warnings": list(warns),
    }


def _report(s: dict, quiet: bool) -> None:
    for w in s["warnings"]:
        print(f"warning: {s['path']}: {w}", file=sys.stderr)
    if not quiet:
        irr = "not measurable" if s["irr"] is None else f"{s['irr']:.1f} dB ({s['irr_from']})"
        print(
            f"{s['out']}: {s['n']} pulses ({s['duration_s']:.2f} s, {s['format']}, {s['layout']}), "
            f"image rejection {irr}",
            file=sys.stderr,
        )
        f = s.get("fmcw")
        if f:
            print(
                f"{s['out']}: FMCW {f['n_chirps']} chirps x {f['n_samples']} samples x {f['n_channels']} "
                f"channel(s), {f['n_cpi']} CPIs of {f['cpi_chirps']} chirps; range bins of {f['range_bin_m']:.3g} m, "
                f"target in bins {f['bins_min']}-{f['bins_max']} ({f['range_bin']}), track "
                f"{s['range_m'][0]:.2f}-{s['range_m'][1]:.2f} m",
                file=sys.stderr,
            )


def run(args) -> int:
    if args.batch and args.recording:
        raise InputError(
            "import",
            "recording",
            f"given together with --batch ({args.recording})",
            "a recording or --batch TABLE.csv, not both",
        )
    if not args.batch and not args.recording:
        raise InputError("import", "recording", "missing", "a recording file, or --batch TABLE.csv")
    if args.batch:
        return run_batch(args)
    check_output(args.out, kind="store", overwrite=args.overwrite)
    sidecar = read_sidecar(args.sidecar) if args.sidecar else {}
    log = load_motor_log(args.motor_log, args.motor_log_unit)
    flight, warns = import_recording(
        args.recording,
        options=_options(args),
        sidecar=sidecar,
        layout=args.layout,
        variable=args.variable,
        default_flight_id=default_flight_id_for(args.out),
        background=args.background,
        force=args.force,
    )
    check_recording(flight, args.recording, warns, force=args.force, rotors=False)
    flight = complete_flight(flight, warns, log=log, log_path=args.motor_log, estimate=args.estimate_motors)
    flight = check_recording(flight, args.recording, warns, force=args.force)
    write_flight(args.out, flight)
    _report(_summary(args.recording, args.out, flight, warns), args.quiet)
    return 0


def check_recording(flight, source, warns: list, *, force: bool = False, rotors: bool = True):
    """Check the declared set-up against the recording itself
    (:func:`microdoppler.rotors.plausibility.recording_problems`: the spectrum's
    Doppler extent; with ``rotors``, the tips at the motor log's rates): a
    contradiction raises :class:`InputError`, or with ``force`` is added to ``warns``
    and the flight's ``plausibility_warnings``. Returns the flight. ``rotors=False``
    checks the spectrum alone and stores nothing (the check with the rotors follows)."""
    from ..importing.plausibility import mark, settle
    from ..rotors.plausibility import recording_problems, spectrum_problems

    if not rotors:
        settle(source, spectrum_problems(flight), force=force)  # refused early, before an estimate
        return flight
    found = settle(source, recording_problems(flight), force=force)
    warns.extend(found)
    return mark(flight, found)


def load_motor_log(path, unit: str = "rpm"):
    """The motor log at ``path`` (ULog, or CSV in ``unit``), or None."""
    if not path:
        return None
    opts = {} if str(path).lower().endswith(".ulg") else {"unit": unit}
    return read_motor_log(path, **opts)


def complete_flight(flight, warns: list, *, log=None, log_path=None, estimate: bool = False):
    """Attach what the recording itself does not hold: the motor log (or rotor speeds
    estimated from the radar when ``estimate`` and there is no log). (The background
    recording is read with the recording: :func:`~microdoppler.importing.import_recording`.)"""
    if log is not None:
        if estimate:
            raise InputError(
                "--estimate-motors",
                "option",
                f"given with a motor log ({log_path})",
                "one source of rotor speeds: the log, or the radar",
            )
        attach_motor_log(flight, log, log_path)
    elif estimate:
        flight = estimate_motors(flight, warns)
    return flight


def attach_motor_log(flight, log, source) -> None:
    """Store ``log`` as the flight's ``motors/*`` (a drone's, with matching motor count)."""
    if flight.attrs.get("target") != "drone":
        raise InputError("--motor-log", "target", f"is {flight.attrs.get('target')!r}", "a drone recording")
    if log.n_motors != flight.attrs.get("n_motors"):
        raise InputError(
            source,
            "motor columns",
            f"{log.n_motors} motors",
            f"n_motors={flight.attrs.get('n_motors')} of the recording",
        )
    flight.motors_time_s, flight.motors_rpm = log.time_s.astype("float64"), log.rpm.astype("float32")
    flight.attrs["motors_source"] = "log"


class FitProgress:
    """The I/Q fit's progress, one line per call on ``stream`` (default stderr): a pass
    ends with its last CPI; a call after that starts the next pass, which the line
    names (the order check measured the speeds again at another order)."""

    def __init__(self, stream=None):
        self.stream = stream
        self.n_pass = 1
        self._ended = False

    def __call__(self, done: int, total: int) -> None:
        if self._ended:
            self.n_pass += 1
        self._ended = done >= total
        label = f" (pass {self.n_pass}: measured again at another order)" if self.n_pass > 1 else ""
        print(
            f"rotor speeds from the radar: I/Q fit{label}, {done} of {total} CPIs",
            file=self.stream or sys.stderr,
            flush=True,
        )


def estimate_motors(flight, warns: list):
    """The flight with rotor speeds estimated from its HERM lines as its motor log, or
    unchanged with the reason in ``warns`` when there is no estimate."""
    from ..rotors.speed import estimate_rotor_speeds

    if flight.attrs.get("target") != "drone":
        raise InputError("--estimate-motors", "target", f"is {flight.attrs.get('target')!r}", "a drone recording")
    progress = FitProgress()
    est = estimate_rotor_speeds(flight, progress=progress)
    if not est.ok:
        warns.append(f"no rotor-speed estimate: {est.reason}")
        flight.attrs["motors_estimate_failed"] = str(est.reason)  # diagnose's hint says so
        return flight
    print(f"rotor speeds from the radar: {est.summary()}", file=sys.stderr)  # information, not a warning
    from ..rotors.order import ambiguity_line

    if (line := ambiguity_line(est)) is not None:
        print(line, file=sys.stderr)
    from ..rotors.plausibility import blade_count_hint

    if (hint := blade_count_hint(est)) is not None:
        print(f"hint: {hint}", file=sys.stderr)
    return est.with_flight(flight)


def _is_own(entry: Path) -> bool:
    return entry.name.endswith(".zarr") and is_tool_store(entry)


def read_batch_table(path) -> list[dict]:
    """Batch table -> one dict per row: ``file`` (Path), ``sidecar`` (Path or None) and
    ``{key: (value, label)}`` for every non-empty parameter cell."""
    path = Path(path)
    if not path.is_file():
        raise InputError(
            path,
            "file",
            "does not exist" if not path.exists() else "is not a file",
            "a CSV table with a column file (one row per recording)",
        )
    try:
        df = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=True)
    except Exception as exc:
        raise InputError(
            path, "file", f"cannot be parsed as CSV ({type(exc).__name__})", "a CSV table with a column file"
        ) from None
    if "file" not in df.columns:
        raise InputError(path, "file", "column missing", "a column file (one recording per row)")
    for c in df.columns:
        if c not in TABLE_COLUMNS:
            raise InputError(path, str(c), "is not a table column", ", ".join(TABLE_COLUMNS))
    if df.empty:
        raise InputError(path, "rows", "none", "one row per recording")
    rows = []
    for i, rec in enumerate(df.to_dict("records")):
        where = f"{path} row {i + 2}"  # line number in the file (header is line 1)
        row = {"line": where, "values": {}}
        for c, v in rec.items():
            v = str(v).strip()
            if not v:
                continue
            label = f"{where} column {c}"
            if c in ROW_FILES or c == "track":
                v = Path(v) if Path(v).is_absolute() else path.parent / v
                if c != "track":
                    row[c] = v
                    continue
            elif c == "motor_log_unit":
                if v not in UNIT_TO_RPM:
                    raise InputError(where, c, f"is {v!r}", " or ".join(UNIT_TO_RPM))
                row[c] = v
                continue
            elif c in PARAM_TYPES:
                v = convert(c, v, where, c)
            elif c == "layout" and v not in LAYOUTS:
                raise InputError(where, c, f"is {v!r}", " or ".join(LAYOUTS))
            elif c == "noise_segment_s":
                v = parse_noise_segment(v, where, c)
            row["values"][c] = (v, label)
        if "file" not in row:
            raise InputError(where, "file", "is empty", "the recording's path")
        rows.append(row)
    return rows


def run_batch(args) -> int:
    check_output(args.out, kind="folder", overwrite=args.overwrite, is_own=_is_own)
    for opt, col in (("flight_id", "flight_id"), ("background", "background"), ("motor_log", "motor_log")):
        if getattr(args, opt):
            raise InputError(
                "--" + opt.replace("_", "-"),
                "option",
                "given with --batch",
                f"a {col} column in the table (one per recording)",
            )
    rows = read_batch_table(args.batch)
    cli_sidecar = read_sidecar(args.sidecar) if args.sidecar else {}
    cli_opts = _options(args)
    out = Path(args.out)
    tmp = atomic_dir(out)
    tmp.mkdir()
    seen = {}
    try:
        results = []
        for row in rows:
            opts = dict(cli_opts)
            vals = row["values"]
            if "track" in vals or "range_m" in vals:  # a row's track replaces the command line's
                opts.pop("track", None)
                opts.pop("range_m", None)
            opts.update({k: v for k, v in vals.items() if k not in EXTRA_KEYS or k in ("track", "noise_segment_s")})
            sidecar = read_sidecar(row["sidecar"]) if "sidecar" in row else cli_sidecar
            flight, warns = import_recording(
                row["file"],
                options=opts,
                sidecar=sidecar,
                layout=vals.get("layout", (args.layout,))[0],
                variable=vals.get("variable", (args.variable,))[0],
                default_flight_id=default_flight_id_for(row["file"]),
                background=row.get("background"),
                force=args.force,
            )
            log = load_motor_log(row.get("motor_log"), row.get("motor_log_unit", args.motor_log_unit))
            check_recording(flight, row["file"], warns, force=args.force, rotors=False)
            flight = complete_flight(
                flight,
                warns,
                log=log,
                log_path=row.get("motor_log"),
                estimate=args.estimate_motors and log is None and flight.attrs.get("target") == "drone",
            )
            flight = check_recording(flight, row["file"], warns, force=args.force)
            fid = flight.flight_id
            if fid in seen:
                raise InputError(
                    row["line"],
                    "flight_id",
                    f"{fid!r} is also the flight id of {seen[fid]}",
                    "one flight id per row (a flight_id column)",
                )
            seen[fid] = row["line"]
            write_flight(tmp / f"{fid}.zarr", flight)
            results.append(_summary(row["file"], out / f"{fid}.zarr", flight, warns))
            del flight  # one recording in memory at a time
        commit_folder(tmp, out, _is_own)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    for s in results:
        _report(s, args.quiet)
    if not args.quiet:
        n = len(results)
        print(
            f"{out}: {n} flight{'s' if n != 1 else ''} (measurements.source: directory, measurements.directory: {out})",
            file=sys.stderr,
        )
    return 0
