"""Write the table of the diagnosis's causes and their parameters from the catalog.

The report page (``docs/report.md``) includes the table, so a cause or a parameter
added to the registry (:mod:`microdoppler.causes`) appears on the page at the next docs
build (``docs/conf.py`` calls :func:`write_table`).
"""

from __future__ import annotations

from pathlib import Path


def causes_table() -> str:
    """The catalog as a Markdown table: cause, what differs, and one line per parameter
    (name, unit, meaning, detectable range)."""
    from microdoppler.causes.catalog import CAUSES

    def cell(text: str) -> str:
        return str(text).replace("|", "\\|").replace("\n", " ")

    rows = [
        "| cause | what is different in the measured data | parameter | unit | meaning | detectable |",
        "|---|---|---|---|---|---|",
    ]
    for cause in CAUSES.values():
        params = cause.params or [None]
        for i, p in enumerate(params):
            head = (f"`{cause.name}`", cell(cause.meaning)) if i == 0 else ("", "")
            tail = ("–", "", "", "") if p is None else (f"`{p.name}`", p.unit, cell(p.meaning), cell(p.detectable))
            rows.append("| " + " | ".join(head + tail) + " |")
    return "\n".join(rows) + "\n"


def write_table(path: Path) -> Path:
    """Write :func:`causes_table` to ``path`` (only when it changed, so that Sphinx does
    not rebuild the page for nothing)."""
    path = Path(path)
    text = causes_table()
    if not path.is_file() or path.read_text() != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return path
