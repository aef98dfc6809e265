"""Writing outputs without ever losing a user's files.

Every store, table and report the tool writes goes through this module:

- :func:`atomic_file` and :func:`atomic_dir` write beside the final path and rename,
  so an interrupted write never leaves a half-written output under its final name;
- :func:`commit_dir` replaces an existing directory only if it is a Zarr store this
  tool wrote (root attribute ``written_by`` = :data:`MARK`, added to every store at
  commit) and holds nothing but Zarr metadata and chunk files; anything else is
  refused with an :class:`~microdoppler.errors.InputError`;
- :func:`check_output` is the command-line check of an ``--out`` path: an existing
  path is refused unless ``overwrite`` is set, and even then only an output of this
  tool's own kind is replaced; ``.``, ``..`` (any directory holding the current one),
  the home directory, a repository root and the file-system root are never outputs.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import uuid
from pathlib import Path

import zarr

from ..errors import InputError

#: the marker attribute every store written by this tool carries
MARK_ATTR = "written_by"
MARK = "microdoppler"
#: file names that make up a Zarr store besides chunk files
_ZARR_META = {"zarr.json", ".zarray", ".zgroup", ".zattrs", ".zmetadata"}
#: JSON files this tool writes carry one of these ``schema`` prefixes
REPORT_SCHEMAS = ("diagnosis-report/", "emulator-key/")
#: the kinds of output :func:`check_output` knows
KINDS = ("store", "report", "folder")


def atomic_dir(final) -> Path:
    """Temporary sibling directory for an atomic write of ``final`` (parents created)."""
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    return final.parent / f".{final.name}.tmp-{uuid.uuid4().hex[:8]}"


@contextlib.contextmanager
def atomic_file(path):
    """Write a file atomically: yields a temporary sibling path (same suffix) to write;
    on success it is renamed to ``path``, on error removed. Parents are created."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{uuid.uuid4().hex[:8]}{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _root_attrs(path: Path) -> dict | None:
    meta = path / "zarr.json"
    if meta.is_file():
        try:
            return json.loads(meta.read_text()).get("attributes", {}) or {}
        except (OSError, ValueError):
            return None
    meta = path / ".zattrs"
    if (path / ".zgroup").is_file():
        try:
            return json.loads(meta.read_text()) if meta.is_file() else {}
        except (OSError, ValueError):
            return None
    return None


def foreign_files(path) -> list[Path]:
    """Files and links under ``path`` that are not part of a Zarr store: anything but
    metadata files, and chunk files below an array's metadata."""
    path = Path(path)
    out = []
    arrays: dict[Path, bool] = {}
    for dirpath, dirnames, filenames in os.walk(path, followlinks=False):
        d = Path(dirpath)
        out += [d / n for n in dirnames if (d / n).is_symlink()]
        up = [d, *(a for a in d.parents if a == path or path in a.parents)]
        in_array = any(arrays.setdefault(a, _is_array(a)) for a in up)
        out += [d / n for n in filenames if (d / n).is_symlink() or not (n in _ZARR_META or in_array)]
    return out


def _is_array(d: Path) -> bool:
    meta = d / "zarr.json"
    if meta.is_file():
        try:
            return json.loads(meta.read_text()).get("node_type") == "array"
        except (OSError, ValueError):
            return False
    return (d / ".zarray").is_file()


def is_tool_store(path) -> bool:
    """True if ``path`` is a Zarr store written by this tool and holds only store files."""
    path = Path(path)
    if path.is_symlink() or not path.is_dir():
        return False
    attrs = _root_attrs(path)
    return bool(attrs) and attrs.get(MARK_ATTR) == MARK and not foreign_files(path)


def mark_store(path) -> None:
    """Add the marker attribute to the root group of the store at ``path``."""
    zarr.open_group(str(path), mode="r+").attrs[MARK_ATTR] = MARK


def commit_dir(tmp, final) -> None:
    """Move the finished store ``tmp`` to ``final``, marking it as written by this tool.

    An existing ``final`` is replaced only if :func:`is_tool_store` (renamed aside,
    the new one renamed in, then the old one removed); anything else raises
    :class:`InputError` and leaves both in place (the caller removes ``tmp``).
    """
    tmp, final = Path(tmp), Path(final)
    if (tmp / "zarr.json").is_file() or (tmp / ".zgroup").is_file():
        mark_store(tmp)
    if not (final.exists() or final.is_symlink()):
        os.replace(tmp, final)
        return
    if not is_tool_store(final):
        raise InputError(
            final,
            "output",
            "exists and is not a store written by microdoppler",
            "a new path (existing files are never replaced)",
        )
    old = final.parent / f".{final.name}.old-{uuid.uuid4().hex[:8]}"
    os.replace(final, old)
    os.replace(tmp, final)
    shutil.rmtree(old)


def commit_folder(tmp, final, is_own) -> None:
    """Move the finished folder ``tmp`` to ``final``.

    An existing ``final`` is replaced only if it is a directory whose every entry
    ``is_own(entry)`` accepts (an empty one included): renamed aside, the new one
    renamed in, then the old one removed. Otherwise :class:`InputError`.
    """
    tmp, final = Path(tmp), Path(final)
    if not (final.exists() or final.is_symlink()):
        os.replace(tmp, final)
        return
    foreign = _foreign_entry(final, is_own)
    if foreign is not None:
        raise InputError(
            final,
            "output",
            f"exists and holds {foreign}, which this tool did not write",
            "a new or empty folder (existing files are never replaced)",
        )
    old = final.parent / f".{final.name}.old-{uuid.uuid4().hex[:8]}"
    os.replace(final, old)
    os.replace(tmp, final)
    shutil.rmtree(old)


def _foreign_entry(folder: Path, is_own) -> str | None:
    if folder.is_symlink() or not folder.is_dir():
        return "no folder (a file or link)"
    for entry in sorted(folder.iterdir()):
        if entry.is_symlink() or not is_own(entry):
            return entry.name
    return None


def _is_report(path: Path) -> bool:
    try:
        schema = json.loads(path.read_text()).get("schema", "")
    except (OSError, ValueError, AttributeError):
        return False
    return isinstance(schema, str) and schema.startswith(REPORT_SCHEMAS)


def _forbidden(path: Path) -> str | None:
    """Why ``path`` can never be an output, or None."""
    p = path.resolve()
    cwd = Path.cwd().resolve()
    if p == Path(p.anchor):
        return "is the file-system root"
    if p == cwd or p in cwd.parents:
        return "is the current directory or holds it"
    if p == Path.home().resolve():
        return "is the home directory"
    if (p / ".git").exists():
        return "is a repository root"
    return None


def check_output(path, *, kind: str, overwrite: bool = False, option: str = "--out", is_own=None) -> Path:
    """Check that ``path`` may be written as an output of ``kind``; returns it.

    Parameters
    ----------
    path : path-like
        The output path given by the user.
    kind : {"store", "report", "folder"}
        ``store``: a Zarr store (directory) this tool writes; ``report``: a JSON
        file with a ``schema`` in :data:`REPORT_SCHEMAS`; ``folder``: a directory of outputs, valid if
        new or empty, or with ``overwrite`` if ``is_own`` accepts every entry in it.
    overwrite : bool
        Allow replacing an existing output of the same kind written by this tool.
    is_own : callable, optional
        ``folder`` only: ``is_own(entry)`` is True for an entry this tool writes there.

    Raises
    ------
    InputError
        Naming ``option``, the path and what was expected. Nothing is written.
    """
    if kind not in KINDS:
        raise ValueError(f"kind={kind!r} must be one of {KINDS}")
    path = Path(path)
    if str(path).strip() == "":
        raise InputError(option, "path", "is empty", "a path")
    why = _forbidden(path)
    if why:
        raise InputError(option, str(path), why, "a new path for the output")
    # the nearest existing ancestor must be a writable directory
    anc = path.parent if str(path.parent) else Path(".")
    while not anc.exists():
        anc = anc.parent
    if not anc.is_dir():
        raise InputError(option, str(path), f"lies below {anc}, which is a file", "a path in a directory")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise InputError(option, str(path), f"cannot be written ({anc} is not writable)", "a writable location")
    if not (path.exists() or path.is_symlink()):
        return path
    if path.is_symlink():
        raise InputError(option, str(path), "is a symbolic link", "a new path for the output")
    if kind == "folder":
        if path.is_dir() and not any(path.iterdir()):
            return path
        if not path.is_dir():
            raise InputError(option, str(path), "exists and is a file", "a new or empty directory")
        if not overwrite:
            raise InputError(
                option,
                str(path),
                "exists and is not empty",
                "a new or empty directory (or --overwrite to replace this tool's own outputs)",
            )
        foreign = _foreign_entry(path, is_own or (lambda e: False))
        if foreign is not None:
            raise InputError(
                option,
                str(path),
                f"holds {foreign}, which this tool did not write",
                "a new or empty directory (--overwrite replaces only this tool's own outputs)",
            )
        return path
    if kind == "store":
        if not path.is_dir():
            raise InputError(option, str(path), "exists and is a file", "a new path for a Zarr store")
        if not overwrite:
            raise InputError(
                option, str(path), "already exists", "a new path (or --overwrite to replace a store this tool wrote)"
            )
        if not is_tool_store(path):
            bad = foreign_files(path)
            what = (
                f"holds files that are not part of a Zarr store ({bad[0].name})"
                if bad
                else "is not a store written by microdoppler"
            )
            raise InputError(
                option, str(path), f"exists and {what}", "a new path (--overwrite replaces only stores this tool wrote)"
            )
        return path
    # report
    if path.is_dir():
        raise InputError(option, str(path), "exists and is a directory", "a new path for a JSON report")
    if not overwrite:
        raise InputError(
            option, str(path), "already exists", "a new path (or --overwrite to replace a report this tool wrote)"
        )
    if not _is_report(path):
        raise InputError(
            option,
            str(path),
            "exists and is not a report written by microdoppler",
            "a new path (--overwrite replaces only this tool's reports)",
        )
    return path
