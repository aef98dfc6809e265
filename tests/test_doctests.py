"""The examples of the documentation run: every ``>>>`` example in the docstrings of
the curated public API (``docs/api.md``) and the code of the user guide's page
``docs/python.md``, each with its printed output checked."""

import doctest
import importlib
import re
import tempfile
from pathlib import Path

import pytest

FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
DOCS = Path(__file__).resolve().parents[1] / "docs"

#: the modules that define the entries of the API reference
CURATED_MODULES = [
    "microdoppler.errors",
    "microdoppler.io.flightzarr",
    "microdoppler.importing.flight",
    "microdoppler.io.motorlog",
    "microdoppler.spectra.periodogram",
    "microdoppler.spectra.spectrogram",
    "microdoppler.spectra.snr",
    "microdoppler.rotors.speed",
    "microdoppler.rotors.sampling",
    "microdoppler.synthesis.radar",
    "microdoppler.synthesis.model",
    "microdoppler.causes.extensions",
    "microdoppler.causes.base",
    "microdoppler.causes.registry",
    "microdoppler.datasets.calibration",
    "microdoppler.causes.twins",
    "microdoppler.datasets.split",
    "microdoppler.datasets.loader",
    "microdoppler.emulator.world",
    "microdoppler.causes.config",
    "microdoppler.causes.measure",
    "microdoppler.diagnosis.pipeline",
    "microdoppler.diagnosis.aggregate",
    "microdoppler.classifier.models",
    "microdoppler.classifier.training",
    "microdoppler.classifier.evaluation",
    "microdoppler.stats.bootstrap",
    "microdoppler.examples",
]


@pytest.fixture(autouse=True)
def _headless(monkeypatch, tmp_path):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.chdir(tmp_path)  # an example that writes a relative path writes here
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # and tempfile.mkdtemp() under pytest's tmp_path


@pytest.mark.parametrize("name", CURATED_MODULES)
def test_docstring_examples_run(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=FLAGS, report=True)
    assert result.attempted > 0, f"{name} has no examples"
    assert result.failed == 0


def test_every_curated_entry_has_an_example():
    """Each entry listed in the API reference has an Examples section that runs."""
    text = (DOCS / "api.md").read_text()
    entries = []
    for block in re.findall(r"```\{eval-rst\}\n(.*?)```", text, flags=re.S):
        module = re.search(r"currentmodule:: (\S+)", block).group(1)
        for line in block.splitlines():
            name = line.strip()
            if line.startswith("   ") and name and not name.startswith(":"):
                entries.append(name if name.startswith("microdoppler.") else f"{module}.{name}")
    assert len(entries) >= 30
    missing = []
    for full in entries:
        mod, _, attr = full.rpartition(".")
        obj = getattr(importlib.import_module(mod), attr)
        doc = obj.__doc__ or ""
        if "Examples\n" not in doc or ">>>" not in doc:
            missing.append(full)
        elif obj.__module__ not in CURATED_MODULES:
            missing.append(f"{full} (module {obj.__module__} not run)")
    assert missing == []


@pytest.mark.slow
@pytest.mark.parametrize(("page", "min_blocks"), [("python.md", 6), ("format.md", 1)])
def test_user_guide_page_runs(page, min_blocks):
    """A page's ``pycon`` blocks (``docs/python.md``, ``docs/format.md``), in order, as one session."""
    text = (DOCS / page).read_text()
    blocks = re.findall(r"^```pycon\n(.*?)^```", text, flags=re.S | re.M)
    assert len(blocks) >= min_blocks
    test = doctest.DocTestParser().get_doctest("\n".join(blocks), {}, page, str(DOCS / page), 0)
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.attempted > 0
    assert result.failed == 0
