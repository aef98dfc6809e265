"""``microdoppler ingest LOG --out STORE.zarr``: motor log -> ``motors/time_s``, ``motors/rpm``.

A bad log exits with status 2 and one line naming the file, the field and what was
expected; nothing is written (the store is written atomically after all checks).
"""

from __future__ import annotations

import sys

from ..io.motorlog import TIME_UNIT_TO_S, UNIT_TO_RPM, read_motor_log, write_motor_store
from ..io.outputs import check_output
from . import add_overwrite, positive_int


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "ingest",
        help="ingest a motor log (PX4 ULog or CSV) into a Zarr store",
        description="Read per-motor speeds from a PX4 ULog (esc_status.esc[i].esc_rpm) or a CSV "
        "(a time column plus one column per motor) and write motors/time_s [s] and "
        "motors/rpm [rev/min] (flight-zarr/1 names) to a Zarr store, atomically.",
    )
    p.add_argument("log", help="motor log file (.ulg or .csv)")
    p.add_argument("--out", required=True, help="output Zarr store (directory)")
    p.add_argument(
        "--format", choices=("ulog", "csv"), default=None, help="log format (default: from the suffix, .ulg or .csv)"
    )
    p.add_argument(
        "--unit",
        choices=tuple(UNIT_TO_RPM),
        default="rpm",
        help="unit of the CSV motor columns (default rpm; ULog esc_rpm is always rpm)",
    )
    p.add_argument("--time-column", default="time_s", help="CSV time column (default time_s)")
    p.add_argument(
        "--time-unit", choices=tuple(TIME_UNIT_TO_S), default="s", help="unit of the CSV time column (default s)"
    )
    p.add_argument(
        "--motor-columns",
        default=None,
        help="comma-separated CSV motor columns (default: every column but the time column)",
    )
    p.add_argument("--n-motors", type=positive_int, default=None, help="expected number of motors (checked)")
    add_overwrite(p)
    p.set_defaults(func=run)


def run(args) -> int:
    check_output(args.out, kind="store", overwrite=args.overwrite)
    opts = {}
    fmt = args.format or ("ulog" if str(args.log).lower().endswith(".ulg") else None)
    if fmt != "ulog":
        opts = dict(
            unit=args.unit,
            time_column=args.time_column,
            time_unit=args.time_unit,
            n_motors=args.n_motors,
            motor_columns=args.motor_columns.split(",") if args.motor_columns else None,
        )
    log = read_motor_log(args.log, args.format, **opts)
    if fmt == "ulog" and args.n_motors is not None and log.n_motors != args.n_motors:
        from ..errors import InputError

        raise InputError(args.log, "esc_status.esc_count", f"{log.n_motors} motors", f"{args.n_motors} motors")
    write_motor_store(args.out, log, attrs={"format": fmt or "csv"})
    print(
        f"{args.out}: {log.n_motors} motors, {len(log.time_s)} rows, {log.duration_s:.2f} s, "
        f"{float(log.rpm.min()):.0f}-{float(log.rpm.max()):.0f} rpm",
        file=sys.stderr,
    )
    return 0
