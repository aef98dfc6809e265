"""``microdoppler emulate``: write an emulated measured world (flight-zarr/1 stores)."""

from __future__ import annotations

from . import add_overwrite, positive_int, seed


def register(subparsers) -> None:
    p = subparsers.add_parser("emulate", help="emulate measured flights (the embedded default world)")
    p.add_argument("--profile", default="default", help="test, default or paper")
    p.add_argument("--seed", type=seed, default=20261121, help="world seed (same seed, identical arrays)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--key", default=None, help="key file (JSON) recording the effects per flight")
    p.add_argument("--workers", type=positive_int, default=None, help="processes (default: min(2, cores))")
    p.add_argument("--quiet", action="store_true")
    add_overwrite(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..errors import InputError
    from ..emulator import PROFILES, emulate_world
    from ..emulator.profiles import is_world_entry
    from ..io.outputs import check_output

    if args.profile not in PROFILES:
        raise InputError("--profile", "profile", f"is {args.profile!r}", " or ".join(PROFILES))
    check_output(args.out, kind="folder", overwrite=args.overwrite, is_own=is_world_entry)
    if args.key:
        check_output(args.key, kind="report", overwrite=args.overwrite, option="--key")
    emulate_world(args.profile, args.seed, args.out, key_path=args.key, progress=not args.quiet, workers=args.workers)
    return 0
