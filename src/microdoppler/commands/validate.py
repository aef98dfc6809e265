"""``microdoppler validate STORE.zarr...``: check flight-zarr/1 stores.

Checks the attributes, dtypes and shapes, that every chunk is stored and readable,
and that every value is finite (streamed chunk by chunk; ``--quick``: metadata only).
Prints ``ok <store>`` per valid store (stdout) and one line per bad store naming the
store, the field and what was expected (stderr); exit status 2 if any store is bad.
A store imported with ``--force`` despite an implausible set-up is valid, and its
stored warning is repeated on stderr.
"""

from __future__ import annotations

import sys

from ..errors import InputError
from ..io.flightzarr import validate_store


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "validate",
        help="validate flight-zarr/1 stores",
        description="Validate flight-zarr/1 stores against the format's definition (docs/format.md).",
    )
    p.add_argument("stores", nargs="+", help="flight-zarr/1 stores (directories)")
    p.add_argument(
        "--quick",
        action="store_true",
        help="check the metadata only (default: also every chunk's presence and content, streamed chunk by chunk)",
    )
    p.set_defaults(func=run)


def run(args) -> int:
    bad = 0
    for store in args.stores:
        try:
            f = validate_store(store, quick=args.quick)
        except InputError as exc:
            print(f"error: {exc}", file=sys.stderr)
            bad += 1
            continue
        print(f"ok {store} ({f.attrs['target']}, {len(f.iq)} pulses, {f.duration_s:.2f} s)")
        for w in f.attrs.get("plausibility_warnings") or []:
            print(f"warning: {store}: imported with --force despite an implausible set-up: {w}", file=sys.stderr)
    return 2 if bad else 0
