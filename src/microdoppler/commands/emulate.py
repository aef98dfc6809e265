"""``microdoppler emulate``: write an emulated measured world (flight-zarr/1 stores)."""

from __future__ import annotations


def register(subparsers) -> None:
    p = subparsers.add_parser("emulate", help="emulate measured flights (the embedded default world)")
    p.add_argument("--profile", default="default", help="test, default or paper")
    p.add_argument("--seed", type=int, default=20261121, help="world seed (same seed, identical arrays)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--key", default=None, help="key file (JSON) recording the effects per flight")
    p.add_argument("--workers", type=int, default=None, help="processes (default: min(2, cores))")
    p.add_argument("--quiet", action="store_true")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..errors import InputError
    from ..emulator import PROFILES, emulate_world

    if args.profile not in PROFILES:
        raise InputError("--profile", "profile", f"is {args.profile!r}", " or ".join(PROFILES))
    emulate_world(args.profile, args.seed, args.out, key_path=args.key, progress=not args.quiet,
                  workers=args.workers)
    return 0
