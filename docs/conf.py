"""Sphinx configuration: MyST pages, an API reference from the numpydoc docstrings, a
gallery of scripts run at build (sphinx-gallery, ``docs/examples/plot_*.py``), and pages
generated at build: the results of a pipeline run (``docs/generate_results.py``), the
benchmarks' records (``docs/generate_benchmarks.py``), the diagnosis's cause table
(``docs/generate_catalog.py``) and the table of configuration keys
(``docs/generate_config.py``).

Build: ``sphinx-build -n -W -b html docs docs/_build/html`` (CI does: nitpicky, warnings
as errors, so every reference to the project's own functions must resolve).
The results page reads the run in ``$MICRODOPPLER_RESULTS`` (default ``../results``).
"""

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "src"))
sys.path.insert(0, str(HERE))

import generate_benchmarks  # noqa: E402
import generate_catalog  # noqa: E402
import generate_config  # noqa: E402
import generate_results  # noqa: E402
import generate_stand_example  # noqa: E402

import microdoppler  # noqa: E402

project = "microdoppler"
author = "the microdoppler developers"
release = microdoppler.__version__
extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "sphinx.ext.mathjax",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
exclude_patterns = ["_build", "_include", "Thumbs.db", ".DS_Store", "examples/GALLERY_HEADER.rst"]
templates_path = ["_templates"]
html_static_path = ["_static"]
html_theme = "alabaster"
myst_heading_anchors = 3
autosummary_generate = True
autodoc_default_options = {"members": True, "ignore-module-all": True}
autodoc_mock_imports = []
# signatures without annotations: the numpydoc Parameters give each type with its
# shape and unit, and annotations would name internal modules' classes
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False

# Links to the libraries beside this one (intersphinx), for each whose inventory
# (objects.inv) can be read at build: a copy in docs/_inventories/NAME.inv (not
# tracked; put one there to build offline), else the library's site. A machine
# without the network (this project's build machines and CI reach package registries
# only) builds without them and says so in one line; nothing else changes.
INTERSPHINX = {
    "python": "https://docs.python.org/3/",
    "numpy": "https://numpy.org/doc/stable/",
    "scipy": "https://docs.scipy.org/doc/scipy/",
    "pandas": "https://pandas.pydata.org/docs/",
    "matplotlib": "https://matplotlib.org/stable/",
    "zarr": "https://zarr.readthedocs.io/en/stable/",
    "torch": "https://docs.pytorch.org/docs/stable/",
}


def _inventory(name: str, url: str):
    """(url, location) of ``name``'s inventory for intersphinx, or None when unreadable."""
    local = HERE / "_inventories" / f"{name}.inv"
    if local.is_file():
        return url, str(local)
    if os.environ.get("MICRODOPPLER_DOCS_OFFLINE"):
        return None
    from urllib.request import urlopen

    try:
        with urlopen(url + "objects.inv", timeout=3) as r:
            r.read(16)
        return url, None
    except (OSError, ValueError):
        return None


extensions.append("sphinx.ext.intersphinx")
intersphinx_mapping = {k: v for k, v in ((n, _inventory(n, u)) for n, u in INTERSPHINX.items()) if v}
intersphinx_timeout = 10
_offline = sorted(set(INTERSPHINX) - set(intersphinx_mapping))
if _offline:
    print(f"intersphinx: no inventory readable for {', '.join(_offline)}: their types stay unlinked")

# Nitpicky builds (``-n``) must resolve every reference to the project's own objects.
# A third-party or standard-library type that no inventory read above resolves stays
# unlinked: only those namespaces are ignored, never ``microdoppler.*``.
nitpicky = True
nitpick_ignore_regex = [
    (r"py:.*", r"(numpy|np|scipy|pandas|pd|zarr|torch|matplotlib|yaml|pyulog)(\..*)?"),
    (r"py:.*", r"(pathlib|logging|collections|typing|os|argparse)\..*"),
]

# the gallery: docs/examples/plot_*.py run at every build, their figures drawn off screen;
# a script that fails fails the build
os.environ.setdefault("MPLBACKEND", "Agg")
sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "gallery",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "write_computation_times": False,
    "matplotlib_animations": False,
    "reset_modules": ("matplotlib", "seaborn"),
}

# the results page: built from a pipeline run's own tables and figures
generate_results.write_page(
    Path(os.environ.get("MICRODOPPLER_RESULTS", HERE.parent / "results")),
    HERE / "results.md",
    HERE / "_static" / "results",
)

# the benchmark page, from the records the benchmark scripts wrote
generate_benchmarks.write_page(HERE.parent / "benchmarks" / "records", HERE / "benchmarks.md")
# the campaign page's example, from the campaign benchmark's records
generate_benchmarks.write_campaign(HERE.parent / "benchmarks" / "records", HERE / "_include" / "campaign.inc")
# the recordings page's stand example, run at build (its transcript and report numbers)
generate_stand_example.write_includes(HERE / "_include")
# the report page's cause table, from the catalog
generate_catalog.write_table(HERE / "_include" / "causes.inc")
# the pipeline page's table of configuration keys, from the settings classes
generate_config.write_table(HERE / "_include" / "config.inc")


def _escape_bars(app, what, name, obj, options, lines):
    """Docstrings write absolute values and norms as ``|x|``; reST would read those as
    substitutions. Escape every bar outside a reST table line."""
    for i, line in enumerate(lines):
        s = line.lstrip()
        if "|" in line and not s.startswith(("|", "+-", "+=")):
            lines[i] = line.replace("\\|", "|").replace("|", "\\|")


def setup(app):
    app.connect("autodoc-process-docstring", _escape_bars, priority=100)
