"""Logging for pipeline scripts: everything a step prints goes to its rule's log."""

from __future__ import annotations

import contextlib
import logging
from pathlib import Path


@contextlib.contextmanager
def log_to(path):
    """Redirect stdout, stderr and the ``logging`` root logger to ``path`` (appending)."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a", buffering=1) as fh:
        handler = logging.StreamHandler(fh)
        handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
        root = logging.getLogger()
        root.addHandler(handler)
        root.setLevel(logging.INFO)
        with contextlib.redirect_stdout(fh), contextlib.redirect_stderr(fh):
            try:
                yield fh
            finally:
                root.removeHandler(handler)


def progress(label: str, every: float = 0.1):
    """A ``progress(done, total)`` callback printing ``label`` at every ``every`` fraction."""
    state = {"next": 0.0}

    def cb(done, total):
        frac = done / max(total, 1)
        if frac >= state["next"] or done >= total:
            print(f"{label}: {100 * frac:5.1f}% ({done}/{total})", flush=True)
            state["next"] = frac + every

    return cb
