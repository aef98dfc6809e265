"""Are two pipeline runs the same? Compares the products of two ``results/`` folders.

A refactoring must leave the pipeline's behaviour unchanged: this script compares, file
by file, the tables (CSV, byte for byte), the diagnosis report (JSON, timings
excepted) and extensions (YAML, byte for byte) and every array of the Zarr stores (``np.array_equal``, NaNs equal;
attributes compared too, except those that record timings or code versions). Files
that record run times (``results/benchmarks/``, logs) are skipped.

Usage::

    python benchmarks/compare_runs.py RESULTS_A RESULTS_B [--only tiles,reports,diagnosis]

Prints one line per product (``same`` / ``DIFFERENT: why`` / ``only in A``) and exits 1
when anything differs.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import zarr

SKIP_DIRS = {"benchmarks", "logs", ".snakemake"}
VOLATILE_ATTRS = ("time", "elapsed", "seconds", "code", "version", "created", "host")
SUFFIX_BYTES = {".csv", ".json", ".yaml", ".tsv"}


def _volatile(key: str) -> bool:
    return any(v in key.lower() for v in VOLATILE_ATTRS)


def _attrs(node) -> dict:
    return _drop_volatile(dict(node.attrs))


def _drop_volatile(obj):
    """``obj`` without the keys (at any depth) that record timings or code versions."""
    if isinstance(obj, dict):
        return {k: _drop_volatile(v) for k, v in obj.items() if not _volatile(k)}
    if isinstance(obj, list):
        return [_drop_volatile(v) for v in obj]
    return obj


def _strip(obj):
    """A JSON value without the keys that record timings."""
    if isinstance(obj, dict):
        return {k: _strip(v) for k, v in obj.items() if k not in ("seconds", "elapsed_s", "wall_s")}
    if isinstance(obj, list):
        return [_strip(v) for v in obj]
    return obj


def compare_json(a: Path, b: Path) -> str | None:
    """None when the two JSON files are equal apart from their timings."""
    if a.read_bytes() == b.read_bytes():
        return None
    ja, jb = _strip(json.loads(a.read_text())), _strip(json.loads(b.read_text()))
    return None if ja == jb else "values differ (timings excepted)"


def compare_store(a: Path, b: Path) -> str | None:
    """None when the two Zarr stores hold the same arrays and attributes, else why not."""
    ga, gb = zarr.open_group(str(a), mode="r"), zarr.open_group(str(b), mode="r")
    if _attrs(ga) != _attrs(gb):
        return "group attributes differ"
    na = {k for k, _ in ga.members(max_depth=None)}
    nb = {k for k, _ in gb.members(max_depth=None)}
    if na != nb:
        return f"members differ: {sorted(na ^ nb)[:5]}"
    for name in sorted(na):
        xa, xb = ga[name], gb[name]
        if isinstance(xa, zarr.Array) != isinstance(xb, zarr.Array):
            return f"{name}: array in one, group in the other"
        if _attrs(xa) != _attrs(xb):
            return f"{name}: attributes differ"
        if isinstance(xa, zarr.Array):
            va, vb = xa[...], xb[...]
            if va.shape != vb.shape or va.dtype != vb.dtype:
                return f"{name}: shape/dtype {va.shape} {va.dtype} vs {vb.shape} {vb.dtype}"
            nan_ok = va.dtype.kind in "fc"
            if not np.array_equal(va, vb, equal_nan=nan_ok):
                return f"{name}: values differ"
    return None


def products(root: Path, only: set[str] | None):
    for p in sorted(root.rglob("*")):
        rel = p.relative_to(root)
        if rel.parts[0] in SKIP_DIRS or (only and rel.parts[0] not in only):
            continue
        if p.suffix == ".zarr" and p.is_dir():
            yield rel
        elif p.is_file() and p.suffix in SUFFIX_BYTES and not any(q.suffix == ".zarr" for q in rel.parents):
            yield rel


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("a", type=Path)
    ap.add_argument("b", type=Path)
    ap.add_argument("--only", default="", help="comma-separated top-level folders to compare (default all)")
    args = ap.parse_args(argv)
    only = {s for s in args.only.split(",") if s} or None
    ra, rb = set(products(args.a, only)), set(products(args.b, only))
    bad = 0
    for rel in sorted(ra | rb):
        if rel not in rb:
            print(f"only in A   {rel}")
            bad += 1
            continue
        if rel not in ra:
            print(f"only in B   {rel}")
            bad += 1
            continue
        pa, pb = args.a / rel, args.b / rel
        if pa.suffix == ".zarr":
            why = compare_store(pa, pb)
        elif pa.suffix == ".json":
            why = compare_json(pa, pb)
        else:
            why = None if pa.read_bytes() == pb.read_bytes() else "bytes differ"
        print(f"{'same' if why is None else 'DIFFERENT: ' + why:<12} {rel}")
        bad += why is not None
    print(f"{len(ra | rb) - bad} same, {bad} different or missing")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
