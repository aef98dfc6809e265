"""Write the table of the pipeline's configuration keys from their definitions.

The pipeline page (``docs/pipeline.md``) includes the table, so a key added to a
settings class (:mod:`microdoppler.settings`) appears on the page, with its default
and meaning, at the next docs build (``docs/conf.py`` calls :func:`write_table`); the
schema ``workflow/schemas/config.schema.yaml`` is generated from the same classes.
"""

from __future__ import annotations

from pathlib import Path


def config_table() -> str:
    """Every configuration key as a Markdown table (:func:`microdoppler.settings.config_table`)."""
    from microdoppler.settings import config_table

    return config_table()


def write_table(path: Path) -> Path:
    """Write :func:`config_table` to ``path`` (only when it changed, so that Sphinx does
    not rebuild the page for nothing)."""
    path = Path(path)
    text = config_table()
    if not path.is_file() or path.read_text() != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return path
