"""``microdoppler diagnose FLIGHT.zarr [...] --out report.json``: name what the paper's
simulation gets wrong about measured drone flights (report format:
shared/formats/flight-zarr.md)."""

from __future__ import annotations

import sys


def register(subparsers) -> None:
    p = subparsers.add_parser("diagnose", help="diagnose measured drone flights against the paper's model",
                              description=__doc__.splitlines()[0])
    p.add_argument("flights", nargs="+", help="flight-zarr/1 stores of drone flights with motor logs")
    p.add_argument("--out", required=True, help="report JSON to write")
    p.add_argument("--figures", default="", help="folder for one figure per flight (default: none)")
    p.add_argument("--config", default="", help="YAML with diagnosis settings (the config's diagnosis: section)")
    p.set_defaults(func=run)


def run(args) -> int:
    import yaml

    from ..diagnosis import diagnose
    from ..errors import InputError

    cfg = {}
    if args.config:
        try:
            with open(args.config) as fh:
                d = yaml.safe_load(fh) or {}
        except OSError as exc:
            raise InputError(args.config, "file", f"cannot be read ({exc.strerror})", "a YAML file") from None
        cfg = d.get("diagnosis", d) if isinstance(d, dict) else {}
    rep = diagnose(args.flights, args.out, config=cfg, figures_dir=args.figures or None,
                   log=lambda m: print(m, file=sys.stderr))
    print(f"wrote {args.out} ({len(rep['flights'])} flights)")
    return 0
