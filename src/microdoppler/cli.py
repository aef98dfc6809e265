"""``microdoppler`` console command.

Each subcommand lives in ``microdoppler.commands.<name>`` and provides
``register(subparsers)``, which adds its parser and sets ``func``. Every error is one
line on stderr naming the file or option, the field and what was expected, with exit
status 2 for bad input (usage, arguments, files) and 1 for a failure of the tool
itself; ``--debug`` shows the traceback. Nothing is written when an input is bad.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from .errors import InputError

COMMANDS = ("ingest", "simulate", "validate", "emulate", "diagnose", "importer", "show")


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (``error: <prog>: <message>``)."""

    def error(self, message):
        self.exit(2, f"error: {self.prog}: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    p = OneLineParser(prog="microdoppler", description=__doc__.splitlines()[0])
    p.add_argument("--debug", action="store_true", help="show the traceback of an error")
    sub = p.add_subparsers(dest="command", required=True, parser_class=OneLineParser)
    for name in COMMANDS:
        mod = importlib.import_module(f"microdoppler.commands.{name}")
        mod.register(sub)
    for sp in sub.choices.values():  # also accepted after the subcommand
        sp.add_argument(
            "--debug", action="store_true", default=argparse.SUPPRESS, help="show the traceback of an error"
        )
    return p


def main(argv=None) -> int:
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # --help, or a usage error already printed in one line
        return int(exc.code or 0)
    try:
        rc = args.func(args)
    except InputError as exc:
        if args.debug:
            raise
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a file the tool could not read or write
        if args.debug:
            raise
        where = exc.filename or "file"
        print(
            f"error: {where}: {exc.strerror or exc} (expected a readable input and a writable output)", file=sys.stderr
        )
        return 2
    except KeyboardInterrupt:
        print("error: interrupted (nothing was written under the output's name)", file=sys.stderr)
        return 130
    except Exception as exc:  # a bug of the tool: still one line, the traceback on request
        if args.debug:
            raise
        print(
            f"error: microdoppler {args.command}: internal error {type(exc).__name__}: {exc} "
            f"(rerun with --debug for the traceback and report it)",
            file=sys.stderr,
        )
        return 1
    return int(rc or 0)


if __name__ == "__main__":
    sys.exit(main())
