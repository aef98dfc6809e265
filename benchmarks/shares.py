"""What the evaluation benchmarks share: a share's Wilson interval and an atomic record.

Imported by the benchmark scripts beside it (``python benchmarks/<script>.py`` puts
this folder on the import path).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path


def wilson(k: int, n: int, z: float = 1.96) -> list:
    """Wilson score interval ``[low, high]`` of the share ``k / n`` (95 % at z = 1.96),
    rounded to 4 decimals; ``[None, None]`` for ``n = 0``."""
    if n == 0:
        return [None, None]
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return [round(max(0.0, c - h), 4), round(min(1.0, c + h), 4)]


def write_record(path, record: dict) -> Path:
    """Write ``record`` as indented JSON to ``path`` atomically (a temporary file beside
    it, then a rename); returns the path."""
    path = Path(path)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(record, indent=1, default=str) + "\n")
    os.replace(tmp, path)
    return path
