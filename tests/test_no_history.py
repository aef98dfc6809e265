"""No project history in the code: commit hashes, issue numbers and flight ids.

The library and the workflow say what a parameter means, its unit and its valid
range; how it was tuned (the commit, the issue, the recordings it was checked on and
the numbers) is recorded in ``docs/experiments.md``. This test scans the text of
every source file of the package and of the workflow (comments, docstrings and
strings alike) for five kinds of token:

- a commit hash: 7 to 40 hexadecimal characters between word boundaries, with at
  least one digit and at least one letter;
- an issue reference: ``issue 12``, ``issues 3 and 4``, ``#12``;
- a flight id of the project's emulated or benchmark recordings: ``any7059``
  (``benchmarks/eval_any_radar.py``), ``f0127`` (``benchmarks/eval_diagnosis.py``,
  ``benchmarks/eval_unexplained.py``), ``p0012_drone`` (``emulator/profiles.py``),
  ``toy0003`` (``classifier/data.py``);
- the seed or plan of a past benchmark run: ``seed 20261126``, ``plans 777-780`` (three
  or more digits; a default seed in code, ``seed: int = 20261121``, is no prose);
- a pointer to the hand-typed results of ``benchmarks/README.md``.

A token that matches but is none of these goes in :data:`ALLOWED` with its reason.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: the files scanned, as globs relative to the repository root
GLOBS = (
    "src/microdoppler/**/*.py",
    "workflow/**/*.py",
    "workflow/**/*.smk",
    "workflow/**/Snakefile",
    "workflow/schemas/*.yaml",
    "Snakefile",
)

HEX_HASH = re.compile(r"\b(?=[0-9a-f]*[0-9])(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}\b", re.IGNORECASE)
ISSUE_REF = re.compile(r"\bissues?\s+#?\d+|(?<![\w&#])#\d+\b", re.IGNORECASE)
FLIGHT_ID = re.compile(r"\b(?:any\d{3,}|f\d{4}|p\d{4}_[a-z]+|toy\d{4})\b")
RUN_ID = re.compile(r"\b(?:seeds?|plans?) \d{3,}\b", re.IGNORECASE)
RESULTS_POINTER = re.compile(r"benchmarks/README\b")

#: (relative path, exact token) -> why the token is not history
ALLOWED = {
    (
        "workflow/schemas/config.schema.yaml",
        "7be5be79",
    ): "part of torchvision's published file name of the AlexNet weights (alexnet-owt-7be5be79.pth)",
    (
        "src/microdoppler/classifier/training.py",
        "7be5be79",
    ): "the same file name, in the description of classifier.alexnet_weights that the schema is generated from",
}

KINDS = (
    ("commit hash", HEX_HASH),
    ("issue reference", ISSUE_REF),
    ("flight id", FLIGHT_ID),
    ("benchmark run", RUN_ID),
    ("results pointer", RESULTS_POINTER),
)


def scanned_files(root: Path = ROOT) -> list[Path]:
    files = {p for g in GLOBS for p in root.glob(g) if p.is_file()}
    return sorted(files)


def history_tokens(text: str, rel: str) -> list[tuple[int, str, str]]:
    """``(line number, kind, token)`` of every history token in ``text`` not allowed for ``rel``."""
    hits = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        for kind, pattern in KINDS:
            for m in pattern.finditer(line):
                if (rel, m.group(0)) not in ALLOWED:
                    hits.append((lineno, kind, m.group(0)))
    return hits


def test_patterns_find_what_they_are_for():
    text = (
        "set in 356bdf1 (issue 34); see #12. any7059 and f0127 and p0012_drone, toy0003\n"
        "on seed 20261126 and plans 777-780 (benchmarks/README.md, 'The I/Q fit')\n"
        "nfft 4096, seed: int = 20261121, seeds 1-3, 1.5e-4, deadbeef, CAFE, f2 and 0x7f, &#123;\n"
    )
    found = [(n, kind, tok) for n, kind, tok in history_tokens(text, "x.py")]
    assert found == [
        (1, "commit hash", "356bdf1"),
        (1, "issue reference", "issue 34"),
        (1, "issue reference", "#12"),
        (1, "flight id", "any7059"),
        (1, "flight id", "f0127"),
        (1, "flight id", "p0012_drone"),
        (1, "flight id", "toy0003"),
        (2, "benchmark run", "seed 20261126"),
        (2, "benchmark run", "plans 777"),
        (2, "results pointer", "benchmarks/README"),
    ]


def test_the_scan_covers_the_package_and_the_workflow():
    rels = {p.relative_to(ROOT).as_posix() for p in scanned_files()}
    assert "src/microdoppler/rotors/order.py" in rels
    assert "workflow/rules/datasets.smk" in rels
    assert "workflow/scripts/diagnose_flights.py" in rels
    assert len(rels) > 50


def test_every_allowed_token_is_still_there():
    """An allow-list entry whose token is gone is removed, so the list stays short."""
    for rel, token in ALLOWED:
        assert token in (ROOT / rel).read_text(encoding="utf-8"), (rel, token)


@pytest.mark.parametrize("path", scanned_files(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_history_in_source(path):
    rel = path.relative_to(ROOT).as_posix()
    hits = history_tokens(path.read_text(encoding="utf-8"), rel)
    assert not hits, "\n".join(f"{rel}:{n}: {kind} {tok!r} (move it to docs/experiments.md)" for n, kind, tok in hits)
