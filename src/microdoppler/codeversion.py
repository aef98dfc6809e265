"""The code a pipeline step runs, and a version hash of it.

A Snakemake rule reruns when one of its ``params`` changes. The workflow passes each
rule the hash of the library modules its script can import (``code=`` in
``workflow/rules/*.smk``), so an edit anywhere in that code reruns the rule and, through
its outputs, every rule after it.

The set of modules is the script's *import closure*: every ``microdoppler`` module the
script imports, at the top level or inside a function, and, recursively, every module
those import, with the ``__init__`` of each package on the way (Python runs them on
import). It is read from the source text (:mod:`ast`), so nothing is executed and a
deferred import counts like any other.
"""

from __future__ import annotations

import ast
import hashlib
from pathlib import Path

PACKAGE = "microdoppler"
PACKAGE_DIR = Path(__file__).resolve().parent


def _module_file(name: str, package_dir: Path) -> Path | None:
    """The file of module ``name`` (dotted, starting with the package), or None."""
    parts = name.split(".")
    if parts[0] != PACKAGE:
        return None
    base = package_dir.joinpath(*parts[1:])
    if base.with_suffix(".py").is_file() and parts[1:]:
        return base.with_suffix(".py")
    if (base / "__init__.py").is_file():
        return base / "__init__.py"
    return None


def _module_name(path: Path, package_dir: Path) -> str:
    rel = path.relative_to(package_dir).with_suffix("")
    parts = [PACKAGE, *rel.parts]
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def imported_modules(source: str, *, module: str | None = None, is_package: bool = False) -> set[str]:
    """Dotted names of the ``microdoppler`` modules that ``source`` may import.

    Parameters
    ----------
    source : str
        Python source text.
    module : str, optional
        The dotted name of the module ``source`` is (needed to resolve relative
        imports; a script outside the package has none).
    is_package : bool
        Whether ``source`` is a package's ``__init__`` (relative imports then start
        at the package itself).

    Returns
    -------
    set of str
        For ``from a.b import c`` both ``a.b`` and ``a.b.c`` are listed (``c`` may be a
        submodule); names that are no module are dropped by :func:`import_closure`.
    """
    names: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                if module is None:
                    continue
                parts = module.split(".")
                keep = len(parts) - node.level + (1 if is_package else 0)
                base = ".".join(parts[:keep] + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            names.add(base)
            names.update(f"{base}.{alias.name}" for alias in node.names if alias.name != "*")
    return {n for n in names if n == PACKAGE or n.startswith(PACKAGE + ".")}


#: (path, mtime_ns, size, module) -> the file's imports: each file is parsed once per
#: process however many scripts import it (the workflow hashes every rule's closure)
_IMPORTS: dict[tuple, frozenset] = {}


def _file_imports(path: Path, module: str | None) -> frozenset:
    """:func:`imported_modules` of the file ``path``, parsed once while it is unchanged."""
    st = path.stat()
    key = (path, st.st_mtime_ns, st.st_size, module)
    if key not in _IMPORTS:
        _IMPORTS[key] = frozenset(
            imported_modules(path.read_text(), module=module, is_package=path.name == "__init__.py")
        )
    return _IMPORTS[key]


def import_closure(script: str | Path, *, package_dir: str | Path = PACKAGE_DIR) -> list[Path]:
    """The library files a script can run: its ``microdoppler`` import closure.

    Parameters
    ----------
    script : str or Path
        A Python file (a workflow script, or a module of the package).
    package_dir : str or Path
        The package's source folder (``src/microdoppler``).

    Returns
    -------
    list of Path
        The closure's files, sorted, each under ``package_dir``.

    Examples
    --------
    >>> from microdoppler.codeversion import PACKAGE_DIR, import_closure
    >>> files = import_closure(PACKAGE_DIR / "spectra" / "snr.py")
    >>> [f.relative_to(PACKAGE_DIR).as_posix() for f in files][:2]
    ['__init__.py', 'spectra/__init__.py']
    """
    package_dir = Path(package_dir).resolve()
    script = Path(script).resolve()
    seen: set[Path] = set()
    todo = [script]
    while todo:
        path = todo.pop()
        inside = package_dir in path.parents
        module = _module_name(path, package_dir) if inside else None
        for name in _file_imports(path, module):
            parts = name.split(".")
            for k in range(1, len(parts) + 1):  # the packages on the way run too
                f = _module_file(".".join(parts[:k]), package_dir)
                if f is not None and f not in seen:
                    seen.add(f)
                    todo.append(f)
        if inside and path not in seen:
            seen.add(path)
            parent = path.parent  # a module's own packages run on import
            while parent != package_dir.parent and (parent / "__init__.py").is_file():
                init = parent / "__init__.py"
                if init not in seen:
                    seen.add(init)
                    todo.append(init)
                parent = parent.parent
    return sorted(seen)


def code_version(script: str | Path, *, package_dir: str | Path = PACKAGE_DIR, version: str = "") -> str:
    """A 16-hex-digit hash of the files in ``script``'s import closure.

    Parameters
    ----------
    script : str or Path
        The workflow script (or module) whose library code is hashed.
    package_dir : str or Path
        The package's source folder.
    version : str
        Mixed into the hash (the package's version).

    Returns
    -------
    str
        Changes when any file of the closure changes, is added to it or leaves it.
    """
    package_dir = Path(package_dir).resolve()
    h = hashlib.sha256(version.encode())
    for f in import_closure(script, package_dir=package_dir):
        h.update(f.relative_to(package_dir).as_posix().encode() + b"\0")
        h.update(f.read_bytes())
    return h.hexdigest()[:16]
