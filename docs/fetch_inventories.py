"""Put the intersphinx inventories that a package registry carries in ``docs/_inventories/``.

The docs link the types of the libraries beside this one (Python, NumPy, SciPy, ...)
through their ``objects.inv``. A machine that reaches their sites needs nothing: the
docs build reads them there (``docs/conf.py``). A machine that reaches package
registries only (this project's build machines and CI) gets the inventories that
Debian's documentation packages carry: Python's (``python3.11-doc``), SciPy's
(``python-scipy-doc``) and pandas' (``python-pandas-doc``). NumPy, matplotlib, zarr
and PyTorch have no such package; their types stay unlinked there.

Usage (CI runs it before the docs build; without ``apt-get`` it writes nothing)::

    python docs/fetch_inventories.py            # into docs/_inventories/
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: name in docs/conf.py's INTERSPHINX -> (Debian package, objects.inv inside it)
DEBIAN = {
    "python": ("python3.11-doc", "usr/share/doc/python3.11/html/objects.inv"),
    "scipy": ("python-scipy-doc", "usr/share/doc/python-scipy-doc/html/objects.inv"),
    "pandas": ("python-pandas-doc", "usr/share/doc/python-pandas-doc/html/objects.inv"),
}


def fetch(out: Path = HERE / "_inventories") -> list[str]:
    """Write ``out/NAME.inv`` for each inventory of :data:`DEBIAN` not there yet;
    returns the names written. Nothing when ``apt-get`` or ``dpkg`` is missing."""
    if not (shutil.which("apt-get") and shutil.which("dpkg")):
        print("fetch_inventories: no apt-get/dpkg here: nothing fetched")
        return []
    out.mkdir(parents=True, exist_ok=True)
    written, updated = [], False
    with tempfile.TemporaryDirectory() as tmp:
        for name, (package, member) in DEBIAN.items():
            target = out / f"{name}.inv"
            if target.is_file():
                continue
            r = subprocess.run(["apt-get", "download", package], cwd=tmp, capture_output=True, text=True)
            if r.returncode and not updated:  # package lists missing or stale: update them once
                subprocess.run(["apt-get", "update", "-qq"], capture_output=True)
                updated = True
                r = subprocess.run(["apt-get", "download", package], cwd=tmp, capture_output=True, text=True)
            debs = sorted(Path(tmp).glob(f"{package}_*.deb"))
            if r.returncode or not debs:
                print(f"fetch_inventories: {package}: not downloaded ({r.stderr.strip().splitlines()[-1:]})")
                continue
            root = Path(tmp) / name
            subprocess.run(["dpkg", "-x", str(debs[-1]), str(root)], check=True)
            src = root / member
            if not src.is_file():
                print(f"fetch_inventories: {package}: no {member}")
                continue
            partial = target.with_suffix(".inv.partial")
            shutil.copyfile(src, partial)
            partial.replace(target)
            written.append(name)
            print(f"fetch_inventories: {name} <- {debs[-1].name}")
    return written


if __name__ == "__main__":
    fetch(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "_inventories")
