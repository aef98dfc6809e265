"""``microdoppler diagnose FLIGHT.zarr [...] --out report.json``: name what the paper's
simulation gets wrong about measured drone flights (report format
``diagnosis-report/2``, defined in ``docs/report.md``)."""

from __future__ import annotations

import sys

from . import add_overwrite


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "diagnose",
        help="diagnose measured drone flights against the paper's model",
        description=__doc__.splitlines()[0],
    )
    p.add_argument(
        "flights",
        nargs="+",
        help="flight-zarr/1 stores (flights that cannot be diagnosed, such as "
        "birds or drones without a motor log, are listed as skipped)",
    )
    p.add_argument(
        "--out",
        required=True,
        help="report JSON to write; a one-row-per-flight table (causes, their "
        "parameters, the causes not testable, the goodness of fit, a skipped "
        "flight's reason and hint) is written beside it as CSV "
        "(report.json -> report.csv)",
    )
    p.add_argument("--figures", default="", help="folder for one figure per flight (default: none)")
    p.add_argument(
        "--config",
        default="",
        help="YAML with diagnosis settings: the pipeline's config file (its diagnosis: section) "
        "or a mapping of diagnosis settings",
    )
    add_overwrite(p)
    p.set_defaults(func=run)


def read_settings(path) -> dict:
    """The diagnosis settings of a YAML file: its ``diagnosis:`` section if it has one
    (the pipeline's config file), else the whole mapping."""
    import yaml

    from ..errors import InputError

    try:
        with open(path) as fh:
            d = yaml.safe_load(fh)
    except OSError as exc:
        raise InputError(path, "file", f"cannot be read ({exc.strerror})", "a YAML file") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or type(exc).__name__
        raise InputError(path, "yaml", f"is not valid YAML ({problem}{where})", "a YAML mapping") from None
    if d is None:
        return {}
    if not isinstance(d, dict):
        raise InputError(path, "yaml", f"is a {type(d).__name__}", "a mapping of settings")
    section = d.get("diagnosis", d) if "diagnosis" in d else d
    if not isinstance(section, dict):
        raise InputError(path, "diagnosis", f"is a {type(section).__name__}", "a mapping of diagnosis settings")
    return section


def check_table(path, report, *, overwrite: bool) -> None:
    """Refuse to replace a table beside the report unless it is one this tool wrote
    (its header is :data:`~microdoppler.diagnosis.pipeline.TABLE_COLUMNS`) and
    ``overwrite`` is set."""
    from pathlib import Path

    from ..diagnosis.pipeline import TABLE_COLUMNS
    from ..errors import InputError

    path = Path(path)
    if path.resolve() == Path(report).resolve():
        raise InputError("--out", str(report), "ends in .csv, the table's own name", "a report path ending in .json")
    if not (path.exists() or path.is_symlink()):
        return
    try:
        ours = path.is_file() and not path.is_symlink() and path.open().readline().strip() == ",".join(TABLE_COLUMNS)
    except (OSError, UnicodeDecodeError):
        ours = False
    if not ours:
        raise InputError(
            "--out",
            str(path),
            "exists and is not a table this tool wrote",
            "a report path whose .csv sibling is new or this tool's",
        )
    if not overwrite:
        raise InputError(
            "--out", str(path), "already exists", "a new path (or --overwrite to replace the tool's table)"
        )


def run(args) -> int:
    from ..diagnosis import diagnose
    from ..diagnosis.pipeline import split_settings, table_path
    from ..io.outputs import check_output

    check_output(args.out, kind="report", overwrite=args.overwrite)
    check_table(table_path(args.out), args.out, overwrite=args.overwrite)
    if args.figures:
        check_output(
            args.figures,
            kind="folder",
            overwrite=args.overwrite,
            option="--figures",
            is_own=lambda e: e.suffix == ".png" and e.is_file(),
        )
    settings = read_settings(args.config) if args.config else {}
    _, cfg = split_settings(settings, source=args.config or "--config")
    rep = diagnose(
        args.flights, args.out, config=cfg, figures_dir=args.figures or None, log=lambda m: print(m, file=sys.stderr)
    )
    print(f"wrote {args.out} and {table_path(args.out)} ({len(rep['flights'])} flights)")
    return 0
