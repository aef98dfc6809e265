"""``microdoppler`` console command.

Each subcommand lives in ``microdoppler.commands.<name>`` and provides
``register(subparsers)``, which adds its parser and sets ``func``. Bad input
(:class:`~microdoppler.errors.InputError`) is printed as one line, exit status 2,
no traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from .errors import InputError

COMMANDS = ("ingest", "simulate", "validate", "emulate", "diagnose")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="microdoppler", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)
    for name in COMMANDS:
        try:
            mod = importlib.import_module(f"microdoppler.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"microdoppler.commands.{name}":
                continue  # command not built yet
            raise
        mod.register(sub)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        rc = args.func(args)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return int(rc or 0)


if __name__ == "__main__":
    sys.exit(main())
