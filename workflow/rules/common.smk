import hashlib
from pathlib import Path

from snakemake.utils import validate

import microdoppler


validate(config, schema="../schemas/config.schema.yaml")

SRC = Path(workflow.current_basedir).parents[1] / "src" / "microdoppler"
MEASURED_SOURCE = config["measurements"]["source"]
MEASURED_DIR = (
    "results/measured"
    if MEASURED_SOURCE == "emulator"
    else config["measurements"]["directory"]
)
VARIANTS = list(config["sampling"]["variants"])


wildcard_constraints:
    variant="|".join(VARIANTS) if VARIANTS else "none",
    seed=r"\d+",


def code_version(*parts):
    """Hash of the library sources a rule depends on (a code edit reruns the rule)."""
    h = hashlib.sha256(microdoppler.__version__.encode())
    for part in parts:
        p = SRC / part
        files = sorted(p.rglob("*.py")) if p.is_dir() else [p]
        if not p.exists():
            raise FileNotFoundError(f"code_version: {p} does not exist")
        for f in files:
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


def motor_logs_table():
    """The flights -> motor logs table, or '' when none is configured."""
    table = config["measurements"]["motor_logs_table"]
    if table:
        return table
    if MEASURED_SOURCE == "emulator":
        return f"{MEASURED_DIR}/motor_logs.tsv"
    return ""


def figure_targets():
    return [
        "results/figures/fig2_herm_lines.png",
        "results/figures/fig8_sampling.png",
    ]


def all_targets():
    targets = ["results/motors/ingest.csv"]
    targets += figure_targets()
    return targets
