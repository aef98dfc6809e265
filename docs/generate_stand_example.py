"""Run the recordings page's end-to-end stand example and write what it printed.

At every docs build (``docs/conf.py`` calls :func:`write_includes`), in a scratch
folder: ``docs/examples/make_stand_recording.py``, then ``microdoppler import ...
--estimate-motors``, ``validate`` and ``diagnose`` in-process, exactly as the page
shows them. Two includes are written: the terminal transcript (``stand_transcript.inc``)
and a paragraph of the numbers the page quotes, read from the report the diagnosis
wrote (``stand_report.inc``). No number on that part of the page is typed by hand.

Usage (also run by ``conf.py``)::

    python docs/generate_stand_example.py docs/_include
"""

from __future__ import annotations

import contextlib
import io
import json
import runpy
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent

COMMANDS = [
    ["import", "stand_3p3ghz.npz", "--sidecar", "stand.yaml", "--estimate-motors", "--out", "stand.zarr"],
    ["validate", "stand.zarr"],
    ["diagnose", "stand.zarr", "--out", "report.json", "--figures", "figs"],
]


def _run(fn) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        fn()
    return out.getvalue()


def run_example(work: Path) -> tuple[str, dict]:
    """Run the example in ``work``; returns (transcript, the flight's report entry)."""
    import os

    from microdoppler.cli import main as cli

    cwd = Path.cwd()
    os.chdir(work)
    try:
        lines = ["$ python docs/examples/make_stand_recording.py"]
        lines += _run(lambda: runpy.run_path(str(HERE / "examples" / "make_stand_recording.py"))).splitlines()
        for argv in COMMANDS:
            lines.append("$ microdoppler " + " ".join(argv))
            rc = []
            text = _run(lambda argv=argv: rc.append(cli(argv)))
            lines += [ln.replace(f"{work}/", "") for ln in text.splitlines()]
            if rc[0] != 0:
                raise RuntimeError(f"microdoppler {' '.join(argv)} exited {rc[0]}:\n{text}")
        report = json.loads((work / "report.json").read_text())
    finally:
        os.chdir(cwd)
    return "\n".join(lines), report["flights"][0]


def paragraph(entry: dict) -> str:
    """The numbers the page quotes, from the flight's report entry."""
    causes = entry.get("causes") or []
    imb = next((c for c in causes if c.get("cause") == "blade_imbalance"), None)
    gof = (entry.get("evidence") or {}).get("goodness_of_fit") or {}
    parts = [f"In `report.json` the flight is `{entry.get('cause')}`"]
    if imb is not None:
        params = (imb.get("extension") or {}).get("params", {})
        iv = ((imb.get("evidence") or {}).get("intervals") or {}).get("imbalance_db") or {}
        ev = imb.get("evidence") or {}
        parts.append(
            f" with `imbalance_db` {params.get('imbalance_db', float('nan')):.1f}"
            + (f" (95 % interval {iv['low']:.1f}-{iv['high']:.1f} dB)" if iv.get("bound") == "two-sided" else "")
            + (
                f", log e-value {ev['log_evalue']:.0f} against a threshold of {ev['log_evalue_threshold']:.1f}"
                if "log_evalue" in ev and "log_evalue_threshold" in ev
                else ""
            )
        )
    if gof:
        band = gof.get("analysed_band_hz") or [None, None]
        parts.append(
            "; with the named causes the model leaves "
            + ("no significant band" if not gof.get("excess") else f"{len(gof.get('bands', []))} significant bands")
            + f" (`evidence.goodness_of_fit`: largest residual {gof.get('max_abs_residual_db')} dB over "
            f"{band[0]:.0f} to {band[1]:.0f} Hz)"
        )
    nt = entry.get("not_testable") or {}
    if nt:
        parts.append(f"; `not_testable` names {', '.join(f'`{c}`' for c in sorted(nt))}")
    return "".join(parts) + "."


def write_includes(folder: Path) -> None:
    """Run the example and write ``stand_transcript.inc`` and ``stand_report.inc``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        transcript, entry = run_example(Path(tmp).resolve())
    for name, text in (
        ("stand_transcript.inc", "```text\n" + transcript + "\n```\n"),
        ("stand_report.inc", paragraph(entry) + "\n"),
    ):
        path = folder / name
        if not path.is_file() or path.read_text() != text:
            path.write_text(text)


if __name__ == "__main__":
    write_includes(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "_include")
