"""Multi-flight Zarr stores of the dataset stages (one group per flight).

``results/speeds/{variant}.zarr``, ``results/synthetic/{variant}.zarr`` and
``results/injected/{variant}.zarr`` hold one group per flight id; the root attrs name
the schema, the variant and the flights that were skipped (with the reason). Every
store is written atomically (temporary sibling, then renamed).
"""

from __future__ import annotations

import shutil
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import zarr

from ..errors import InputError
from ..io.outputs import atomic_dir, commit_dir
from ..synthesis.processes import stable_seed  # noqa: F401 (re-exported)


@contextmanager
def writing_store(path, attrs: dict):
    """Open a new Zarr group at a temporary sibling of ``path``; rename on success.

    Yields the root group. On an exception nothing is left under ``path``'s name.
    """
    path = Path(path)
    tmp = atomic_dir(path)
    try:
        root = zarr.open_group(str(tmp), mode="w", zarr_format=3)
        root.attrs.update(attrs)
        yield root
        commit_dir(tmp, path)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def put_array(group, name: str, data: np.ndarray, chunk_rows: int = 1 << 18):
    """Write ``data`` as array ``name`` of ``group``, chunked along the first axis."""
    data = np.asarray(data)
    chunks = (min(chunk_rows, max(1, data.shape[0])),) + data.shape[1:]
    z = group.create_array(name, shape=data.shape, dtype=data.dtype, chunks=chunks)
    z[...] = data
    return z


def open_store(path, schema: str):
    """Open a dataset store for reading; checks its ``schema`` attribute."""
    path = Path(path)
    if not path.exists():
        raise InputError(path, "store", "does not exist", f"a {schema} Zarr store")
    try:
        root = zarr.open_group(str(path), mode="r")
    except Exception as exc:
        raise InputError(path, "store", f"is not a Zarr group ({type(exc).__name__})", f"a {schema} store") from None
    if root.attrs.get("schema") != schema:
        raise InputError(path, "attrs.schema", f"is {root.attrs.get('schema')!r}", repr(schema))
    return root


def flight_ids(root) -> list[str]:
    """Flight groups of a dataset store, sorted."""
    return sorted(name for name, _ in root.groups())
