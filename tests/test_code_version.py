"""Reruns follow the code: every rule hashes its script's import closure.

- each rule of the workflow that runs a script passes ``code=script_code(<that
  script>)`` (so no rule hashes a hand-picked list of files);
- the closure read from the source text holds every library module that importing the
  script really loads (checked in a fresh interpreter), and the imports a static reader
  can miss (inside functions, relative, through a package's ``__init__``) on a toy
  package;
- the hash changes when any module of the closure changes and not when one outside it
  does.

The dry-run probe after a complete run is in ``test_workflow_runs.py`` (slow).
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from microdoppler.codeversion import PACKAGE_DIR, code_version, import_closure

REPO = Path(__file__).resolve().parents[1]
SCRIPTS = REPO / "workflow" / "scripts"
RULES = sorted((REPO / "workflow" / "rules").glob("*.smk"))


def rule_blocks():
    """(rule name, its text) for every rule in workflow/rules/*.smk."""
    for smk in RULES:
        text = smk.read_text()
        starts = [m for m in re.finditer(r"(?m)^\s*rule (\w+):", text)]
        for i, m in enumerate(starts):
            end = starts[i + 1].start() if i + 1 < len(starts) else len(text)
            yield m.group(1), text[m.start() : end]


def test_every_rule_with_a_script_hashes_that_scripts_import_closure():
    seen = set()
    for name, block in rule_blocks():
        script = re.search(r'script:\s*\n\s*"\.\./scripts/([\w.]+)"', block)
        if script is None:
            continue
        seen.add(script.group(1))
        code = re.findall(r"(?m)^\s*code=(.*),\s*$", block)
        assert code == [f'script_code("{script.group(1)}")'], (
            f'rule {name}: expected params code=script_code("{script.group(1)}"), got {code}'
        )
    assert seen == {p.name for p in SCRIPTS.glob("*.py")}, "a workflow script no rule runs, or the reverse"


LOADER = """
import ast, json, sys
out = {}
for path in sys.argv[1:]:
    for name in [n for n in sys.modules if n.split(".")[0] == "microdoppler"]:
        del sys.modules[name]  # the library afresh; numpy, torch, ... stay loaded
    tree = ast.parse(open(path).read())
    imports = [n for n in tree.body if isinstance(n, (ast.Import, ast.ImportFrom))]
    exec(compile(ast.Module(body=imports, type_ignores=[]), path, "exec"), {})
    out[path] = sorted(m.__file__ for n, m in list(sys.modules.items())
                       if n.split(".")[0] == "microdoppler" and getattr(m, "__file__", None))
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def loaded_modules():
    """script name -> the package's files that running its top-level imports loads."""
    scripts = sorted(SCRIPTS.glob("*.py"))
    out = subprocess.run(
        [sys.executable, "-c", LOADER, *map(str, scripts)],
        capture_output=True,
        text=True,
        check=True,
        env={"PYTHONPATH": str(PACKAGE_DIR.parent), "MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin"},
    )
    return {Path(k).name: {Path(f).resolve() for f in v} for k, v in json.loads(out.stdout).items()}


@pytest.mark.slow
@pytest.mark.parametrize("script", sorted(p.name for p in SCRIPTS.glob("*.py")))
def test_the_closure_holds_every_module_an_import_loads(script, loaded_modules):
    closure = set(import_closure(SCRIPTS / script))
    loaded = loaded_modules[script]
    assert loaded, f"{script} imports no library module"
    missing = sorted(str(p.relative_to(PACKAGE_DIR)) for p in loaded - closure)
    assert not missing, f"{script}: loaded on import but not hashed: {missing}"


@pytest.fixture
def toy(tmp_path):
    """A package ``microdoppler`` in tmp_path with every form of import."""
    pkg = tmp_path / "microdoppler"
    files = {
        "__init__.py": "",
        "a/__init__.py": "from .b import f\n",
        "a/b.py": "def f():\n    from ..c import deep  # deferred, relative\n    return deep\n",
        "c/__init__.py": "",
        "c/deep.py": "import microdoppler.d.e as e\n",
        "d/__init__.py": "",
        "d/e.py": "X = 1\n",
        "d/unused.py": "Y = 2\n",
        "g/__init__.py": "from microdoppler.a import b\n",
        "g/h.py": "from . import i\n",
        "g/i.py": "",
    }
    for rel, text in files.items():
        (pkg / rel).parent.mkdir(parents=True, exist_ok=True)
        (pkg / rel).write_text(text)
    script = tmp_path / "script.py"
    script.write_text(
        textwrap.dedent("""\
        import os
        from microdoppler.a import f
        """)
    )
    return pkg, script


def test_closure_follows_deferred_relative_and_package_imports(toy):
    pkg, script = toy
    rel = {p.relative_to(pkg).as_posix() for p in import_closure(script, package_dir=pkg)}
    assert rel == {"__init__.py", "a/__init__.py", "a/b.py", "c/__init__.py", "c/deep.py", "d/__init__.py", "d/e.py"}
    # a module's own package (its __init__) is part of its closure, and `from . import x`
    rel = {p.relative_to(pkg).as_posix() for p in import_closure(pkg / "g" / "h.py", package_dir=pkg)}
    assert {"g/__init__.py", "g/i.py", "a/b.py", "d/e.py"} <= rel


def test_hash_changes_with_a_module_of_the_closure_only(toy):
    pkg, script = toy
    before = code_version(script, package_dir=pkg)
    (pkg / "d" / "unused.py").write_text("Y = 3\n")
    assert code_version(script, package_dir=pkg) == before
    (pkg / "d" / "e.py").write_text("X = 1  # a comment\n")
    after = code_version(script, package_dir=pkg)
    assert after != before
    assert code_version(script, package_dir=pkg, version="2") != after


@pytest.mark.slow
def test_the_modules_that_once_reran_nothing_are_hashed():
    """Modules an edit of which once reran no rule: each is in some rule's closure."""
    hashed = set().union(*(import_closure(p) for p in SCRIPTS.glob("*.py")))
    for rel in (
        "synthesis/radar.py",
        "synthesis/processes.py",
        "spectra/floor.py",
        "io/flightzarr.py",
        "rotors/order.py",
        "rotors/fit.py",
    ):
        assert PACKAGE_DIR / rel in hashed, rel
