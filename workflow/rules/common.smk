import os
import re
import shutil
import sys
from pathlib import Path

import yaml
from snakemake.exceptions import WorkflowError
from snakemake.utils import validate

import microdoppler
import microdoppler.codeversion
import microdoppler.diagnosis.pipeline
import microdoppler.errors

SCHEMA = Path(workflow.current_basedir).parent / "schemas" / "config.schema.yaml"
# The schema is generated from the settings classes (python -m microdoppler.settings
# schema). An unknown key (a typo) is an error, in one line naming it and its section;
# the diagnosis section first, whose check names what replaced a removed setting.
try:
    DIAGNOSIS_PIPELINE, _ = microdoppler.diagnosis.pipeline.split_settings(
        config.get("diagnosis")
    )
    microdoppler.errors.check_config_keys(config, yaml.safe_load(SCHEMA.read_text()))
except microdoppler.errors.ConfigError as exc:
    sys.exit(f"error: {exc}")
validate(config, schema="../schemas/config.schema.yaml")

SRC = Path(workflow.current_basedir).parents[1] / "src" / "microdoppler"
SCRIPTS = Path(workflow.current_basedir).parent / "scripts"
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


def script_code(script):
    """Hash of the library code ``script`` can run (its import closure).

    Each rule passes it as its ``code`` param, so an edit of any module the script
    imports, directly, inside a function or through other modules, reruns it
    (microdoppler.codeversion).
    """
    return microdoppler.codeversion.code_version(
        SCRIPTS / script, package_dir=SRC, version=microdoppler.__version__
    )


# --- interrupted runs ---
# A killed run leaves its running jobs' outputs marked incomplete (rerun by the
# default workflow profile, profiles/default/config.yaml) and, beside them, the
# hidden temporaries of the library's atomic writes (microdoppler.io.outputs:
# .<name>.tmp-<hex>[.<ext>] and .<name>.old-<hex>), which are no declared output.
# A real run removes those under results/ before its first job (onstart runs while
# Snakemake holds the working directory's lock, so no job of ours is writing them).
STALE_TEMPORARY = re.compile(r"\..+\.(tmp|old)-[0-9a-f]{8}(\.[^.]+)?")


def remove_stale_temporaries(root="results"):
    """Remove the atomic-write temporaries a killed run left under ``root``."""
    removed = []
    for dirpath, dirnames, filenames in os.walk(root):
        for name in [n for n in dirnames + filenames if STALE_TEMPORARY.fullmatch(n)]:
            path = os.path.join(dirpath, name)
            if os.path.isdir(path) and not os.path.islink(path):
                shutil.rmtree(path)
                dirnames.remove(name)
            else:
                os.unlink(path)
            removed.append(path)
    return removed


onstart:
    for path in remove_stale_temporaries():
        print(f"removed {path} (left by an interrupted run)", file=sys.stderr)


def motor_logs_table():
    """The flights -> motor logs table, or '' when none is configured."""
    table = config["measurements"]["motor_logs_table"]
    if table:
        return table
    if MEASURED_SOURCE == "emulator":
        return f"{MEASURED_DIR}/motor_logs.tsv"
    return ""


# --- diagnosis (rules/diagnosis.smk) ---
#: the diagnosis jobs' `{part}` values (diagnosis.flight_batches)
DIAGNOSIS_PARTS = [str(p) for p in range(DIAGNOSIS_PIPELINE["flight_batches"])]


def extended_first(wildcards):
    """Priority of a variant's, dataset's or training set's job: the `extended`
    variant's first (it waits for the diagnosis, so its chain is the run's critical
    path); only the order of jobs changes, never a result."""
    names = {wildcards.get(k) for k in ("variant", "dataset", "trainset")}
    return 10 if "extended" in names else 0


# --- datasets (rules/datasets.smk) ---
DATASETS = ["real"] + VARIANTS
TWIN_MODELS = ["inspire2", "matrice300"]  # the emulated world's (paper Fig. 9/10)


def campaign_twin_models():
    """A campaign of your own: its drone models that get twins (one figure each)."""
    from microdoppler.datasets.split import twin_model
    from microdoppler.io.inventory import drone_models

    return [m for m in drone_models(MEASURED_DIR) if twin_model(m)]


if MEASURED_SOURCE == "directory" and Path(MEASURED_DIR).is_dir():
    TWIN_MODELS = campaign_twin_models()
MOTOR_LOGS = "results/motors/logs.zarr"
SPLIT = "results/splits/flights.csv"

# Flight batches (datasets.flight_batches): with N > 1, synthesize_flights and
# inject_background run once per (variant, batch) on the flights whose stable id hash
# falls in the batch (microdoppler.datasets.batches.flight_batch), and rule
# merge_flight_batches gathers them into the per-variant products. With N = 1 they
# write those products directly (today's jobs and paths).
FLIGHT_BATCHES = int(config["datasets"]["flight_batches"])
BATCHES = [str(b) for b in range(FLIGHT_BATCHES)]
VARIANT_BATCH = "{variant}" if FLIGHT_BATCHES == 1 else "{variant}/batch{batch}"
SYNTHETIC_BATCH = f"results/synthetic/{VARIANT_BATCH}.zarr"
INJECTED_BATCH = f"results/injected/{VARIANT_BATCH}.zarr"
TABLE_IV_BATCH = (
    "results/reports/table_iv_{variant}.csv"
    if FLIGHT_BATCHES == 1
    else "results/reports/table_iv_{variant}/batch{batch}.csv"
)


wildcard_constraints:
    dataset="|".join(DATASETS),
    batch="|".join(BATCHES),


def variant_settings(wildcards):
    """This variant's own sampling settings (extended falls back to sub_cpi's)."""
    per = config["sampling"].get("per_variant", {})
    v = wildcards.variant
    return dict(per.get(v, per.get("sub_cpi", {}) if v == "extended" else {}))


def extensions_input(wildcards):
    """The diagnosis' model extensions, for the extended variant only."""
    if wildcards.variant == "extended":
        return {"extensions": config["datasets"]["extensions"]}
    return {}


def speeds_inputs(wildcards):
    return {"measured": MEASURED_DIR, "logs": MOTOR_LOGS, **extensions_input(wildcards)}


def twins_inputs(wildcards):
    return {
        "measured": MEASURED_DIR,
        "logs": MOTOR_LOGS,
        "speeds": f"results/speeds/{wildcards.variant}.zarr",
        **extensions_input(wildcards),
    }


def tile_inputs(wildcards):
    """Measured flights and the split; a variant adds its injected twins."""
    inputs = {"measured": MEASURED_DIR, "split": SPLIT}
    if wildcards.dataset != "real":
        inputs["injected"] = f"results/injected/{wildcards.dataset}.zarr"
    return inputs


def dataset_targets():
    """Everything the dataset stages produce (for rule all)."""
    return (
        [SPLIT, "results/reports/table_iii.csv", "results/reports/table_iv.csv"]
        + expand("results/tiles/{dataset}.zarr", dataset=DATASETS)
        + expand("results/figures/twins_{model}.png", model=TWIN_MODELS)
    )


# --- classifier (rules/classifier.smk) ---
CLASSIFIER = config.get("classifier", {})
TRAINSETS = CLASSIFIER.get("trainsets") or ["real"] + VARIANTS
SEEDS = [int(s) for s in CLASSIFIER.get("seeds", list(range(1, 10)))]
CLASSIFIER_GPUS = 1 if CLASSIFIER.get("architecture") == "alexnet" else 0


def classifier_note():
    """Why a campaign of your own cannot train the bird/drone classifier, or ''.

    One line (microdoppler.io.inventory.missing_class_note); the emulated world has both classes.
    """
    if MEASURED_SOURCE != "directory" or not Path(MEASURED_DIR).is_dir():
        return ""
    from microdoppler.io.inventory import missing_class_note

    return missing_class_note(MEASURED_DIR)


CLASSIFIER_NOTE = classifier_note()


def classifier_tiles(wildcards):
    """Tile stores a training set needs: the measured one, plus the variant's twins."""
    if CLASSIFIER_NOTE:
        # a classifier target asked for explicitly: fail before any job runs
        raise WorkflowError(CLASSIFIER_NOTE)
    stores = {"real": "results/tiles/real.zarr"}
    if wildcards.trainset != "real":
        stores["variant"] = f"results/tiles/{wildcards.trainset}.zarr"
    return stores


def classifier_predictions():
    return expand(
        "results/eval/{trainset}/seed{seed}.csv", trainset=TRAINSETS, seed=SEEDS
    )


def classifier_targets():
    return [
        "results/reports/metrics.csv",
        "results/reports/table_v.csv",
        "results/reports/fig12_boxplot.png",
    ]


def figure_targets():
    return [
        "results/figures/fig2_herm_lines.png",
        "results/figures/fig8_sampling.png",
    ]


def all_targets():
    """Every target of the default run (rule all), but the per-rule times (which
    follow them all); the classifier's note printed once."""
    return ALL_TARGETS


def _all_targets():
    targets = ["results/motors/ingest.csv"]
    targets += figure_targets()
    targets += dataset_targets()
    if not CLASSIFIER_NOTE:
        targets += classifier_targets()
    elif workflow.is_main_process:
        print(CLASSIFIER_NOTE, file=sys.stderr)
    targets += ["results/diagnosis/report.json", "results/diagnosis/extended.yaml"]
    targets += ["results/reports/table_vi.csv", "results/reports/fig_fidelity.png"]
    return targets


ALL_TARGETS = _all_targets()


# --- per-rule times (rules/runtimes.smk) ---
#: the values each wildcard of a benchmark file takes in this run
BENCHMARK_WILDCARDS = {
    "part": DIAGNOSIS_PARTS,
    "variant": VARIANTS,
    "batch": BATCHES,
    "dataset": DATASETS,
    "trainset": TRAINSETS,
}


def rule_benchmark_files(wildcards):
    """Every benchmark file the jobs of this run write (each rule's ``benchmark:``
    pattern over its wildcards' values; the classifier's only where it runs)."""
    skip = (
        {"train_classifier", "evaluate_classifier", "report_metrics"}
        if CLASSIFIER_NOTE
        else set()
    )
    files = []
    for r in workflow.rules:
        if r.name in skip or not r.benchmark:
            continue
        pattern = re.sub(r"{(\w+),[^}]*}", r"{\1}", str(r.benchmark))  # constraints off
        names = set(re.findall(r"{(\w+)}", pattern))
        files += expand(pattern, **{n: BENCHMARK_WILDCARDS[n] for n in names})
    return sorted(set(files))
