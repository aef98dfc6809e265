"""Subcommands of the ``microdoppler`` console command (one module each), and the
argument types they share: each rejects a bad value at parse time, so the message
names the option and what was expected (``argument --prf-hz: is inf (expected a
finite number > 0)``)."""

from __future__ import annotations

import argparse
import math


def _number(kind, text: str, expected: str):
    try:
        v = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"is {text!r} (expected {expected})") from None
    return v


def _typed(kind, test, expected: str):
    def parse(text: str):
        v = _number(kind, text, expected)
        if (kind is float and not math.isfinite(v)) or not test(v):
            raise argparse.ArgumentTypeError(f"is {text} (expected {expected})")
        return v

    parse.__name__ = expected  # argparse names the type in some messages
    return parse


finite = _typed(float, lambda v: True, "a finite number")
positive = _typed(float, lambda v: v > 0, "a finite number > 0")
non_negative = _typed(float, lambda v: v >= 0, "a finite number >= 0")
positive_int = _typed(int, lambda v: v >= 1, "an integer >= 1")
seed = _typed(int, lambda v: 0 <= v < 2**63, "an integer seed in [0, 2^63)")


def add_overwrite(parser) -> None:
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an existing output of the same kind that this tool wrote (never anything else)",
    )
