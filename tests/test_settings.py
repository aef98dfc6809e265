"""One definition of the configuration (microdoppler.settings): the schema file, the
defaults of config/config.yaml and the docs' table come from the settings classes, and
every way into the pipeline or a command rejects an unknown key in one line."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from microdoppler import settings
from microdoppler.classifier.training import WORKFLOW_KEYS, ClassifierRuns, TrainConfig
from microdoppler.configfields import config_names
from microdoppler.datasets.calibration import CalibrationConfig
from microdoppler.datasets.fidelity import FidelityConfig
from microdoppler.diagnosis import DiagnosisConfig
from microdoppler.diagnosis.pipeline import PIPELINE_KEYS, DiagnosisRuns, split_settings
from microdoppler.errors import ConfigError
from microdoppler.spectra.spectrogram import SpectrogramSettings

REPO = Path(__file__).resolve().parents[1]
SCHEMA = REPO / settings.SCHEMA_PATH
CONFIG = yaml.safe_load((REPO / "config" / "config.yaml").read_text())

#: keys config/config.yaml sets to other than their defaults, and why (docs/pipeline.md says so too)
OVERRIDES = {
    ("sampling", "variants"): "the embedded default builds every variant, extended too",
    ("sampling", "per_variant"): "the paper's averaging windows (1500-3000 pulses) and spread",
    ("spectrogram", "window_s"): "the paper's 0.56 s written out (the default reaches it)",
    ("spectrogram", "doppler_span_mps"): "the paper's 95 m/s written out (the default reaches it)",
}


def test_schema_file_is_generated_from_the_settings_classes():
    assert SCHEMA.read_text() == settings.schema_yaml(), "run: python -m microdoppler.settings schema"


def test_every_key_has_a_description_a_default_and_no_section_is_open():
    def walk(props, path):
        for key, entry in props.items():
            where = f"{path}.{key}"
            assert entry.get("description"), where
            if not path.startswith(".sampling.per_variant") or path.count(".") > 2:
                assert "default" in entry, where
            if entry.get("type") == "object" and "properties" in entry:
                assert entry.get("additionalProperties") is False, where
                walk(entry["properties"], where)

    schema = settings.config_schema()
    assert schema["additionalProperties"] is False
    for name, section in schema["properties"].items():
        assert section["additionalProperties"] is False and section["description"], name
        walk(section["properties"], f".{name}")


def test_config_yaml_sets_the_defaults_or_a_documented_override():
    defaults = settings.defaults()
    differ = set()
    for section, values in CONFIG.items():
        assert section in defaults, section
        for key, value in values.items():
            assert key in defaults[section], f"{section}.{key}"
            want = defaults[section][key]
            if isinstance(want, dict) and isinstance(value, dict) and want:
                value = {**want, **{k: ({**want[k], **v} if isinstance(v, dict) else v) for k, v in value.items()}}
            if value != want:
                differ.add((section, key))
    assert differ == set(OVERRIDES)


def test_library_defaults_are_the_pipeline_defaults():
    d = settings.defaults()
    assert d["spectrogram"] == {k: getattr(SpectrogramSettings(), k) for k in config_names(SpectrogramSettings)}
    cal = CalibrationConfig()
    assert d["datasets"]["calibration"] == {k: getattr(cal, k) for k in config_names(CalibrationConfig)}
    pipe, cfg = split_settings({k: d["diagnosis"][k] for k in d["diagnosis"]})
    assert cfg == DiagnosisConfig() and pipe == split_settings(None)[0]
    # the classifier's pipeline defaults differ from TrainConfig's in two keys only (Section.defaults)
    train = TrainConfig.from_config(d["classifier"])
    assert train.average_last_epochs == 4 and train.compact == {
        "channels": [6, 12, 24],
        "doppler_pool": 8,
        "dropout": 0.2,
    }
    assert {k for k in config_names(TrainConfig) if getattr(train, k) != getattr(TrainConfig(), k)} == set(
        settings.SECTIONS["classifier"].defaults
    )
    assert WORKFLOW_KEYS == set(config_names(ClassifierRuns))
    assert PIPELINE_KEYS == tuple(config_names(DiagnosisRuns))


def test_shipped_and_test_configs_hold_only_known_keys():
    for path in [*sorted((REPO / "config").glob("*.yaml")), *sorted((REPO / "tests").rglob("*.yaml"))]:
        cfg = yaml.safe_load(path.read_text())
        if isinstance(cfg, dict) and set(cfg) & set(settings.SECTIONS) and set(cfg) <= set(settings.SECTIONS):
            settings.check_config(cfg, source=path)


def _one_line(call, where):
    with pytest.raises(ConfigError) as err:
        call()
    msg = str(err.value)
    assert "\n" not in msg, msg
    section = where.rsplit(".", 1)[0]
    assert f"{where}: unknown key in section {section} (expected one of: " in msg, msg
    return msg


@pytest.mark.parametrize(
    "call, where",
    [
        (lambda: SpectrogramSettings.from_config({"nfft": 4096}), "spectrogram.nfft"),
        (lambda: TrainConfig.from_config({"epoch": 3}), "classifier.epoch"),
        (lambda: TrainConfig.from_config({"augment": {"stretch": 0.1}}), "classifier.augment.stretch"),
        (lambda: TrainConfig.from_config({"normalisation": {"low": 0}}), "classifier.normalisation.low"),
        (lambda: TrainConfig.from_config({"compact": {"chanels": [4]}}), "classifier.compact.chanels"),
        (lambda: CalibrationConfig.from_config({"tolerance": 2.0}, 10.0), "datasets.calibration.tolerance"),
        (
            lambda: FidelityConfig.from_config({"clutter_span_hz": 30.0, "max_lag_cpis": 16, "nboot": 9}, {}, 10.0),
            "fidelity.nboot",
        ),
        (lambda: FidelityConfig.from_config(CONFIG["fidelity"], {"visible": 1}, 10.0), "datasets.calibration.visible"),
        (lambda: DiagnosisConfig.from_dict({"alpah": 0.05}), "diagnosis.alpah"),
        (lambda: split_settings({"set": ["train"]}), "diagnosis.set"),
        (lambda: settings.SECTIONS["emulator"].check({"sed": 1}), "emulator.sed"),
        (lambda: settings.check_config({**CONFIG, "datasets": {"splitt": {}}}), "datasets.splitt"),
        (
            lambda: settings.check_config({**CONFIG, "sampling": {"per_variant": {"sub_cpi": {"per_cpu": 8}}}}),
            "sampling.per_variant.sub_cpi.per_cpu",
        ),
    ],
)
def test_every_config_path_rejects_an_unknown_key_in_one_line(call, where):
    _one_line(call, where)


def test_a_removed_diagnosis_setting_still_says_what_replaced_it():
    msg = _one_line(lambda: DiagnosisConfig.from_dict({"lag_step_s": 0.02}), "diagnosis.lag_step_s")
    assert "DiagnosisConfig.lag_step_s" in msg and "no longer a setting" in msg


def test_the_pipeline_rejects_an_unknown_key_in_one_line(tmp_path):
    """The pipeline's path: a config file with a typo stops `snakemake -n` before any
    job, with one line naming the key and its section."""
    bad = tmp_path / "bad.yaml"
    bad.write_text("classifier:\n  epoch: 3\n")
    exe = Path(sys.executable).with_name("snakemake")
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    r = subprocess.run(
        [str(exe), "-n", "--quiet", "rules", "-s", str(REPO / "Snakefile"), "-d", str(REPO), "--configfile", str(bad)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert r.returncode != 0
    lines = [ln for ln in (r.stdout + r.stderr).splitlines() if "unknown key" in ln]
    assert lines == [
        "error: config: classifier.epoch: unknown key in section classifier (expected one of: "
        + ", ".join(sorted(settings.SECTIONS["classifier"].keys()))
        + ")"
    ], r.stderr[-2000:]


def test_commands_reject_an_unknown_key_in_their_config_file(tmp_path, capsys):
    """The CLI's path: `show --config` and `diagnose --config` read the pipeline's
    config file; a typo in the section they read is one line and exit status 1."""
    from microdoppler.cli import main

    bad = tmp_path / "my.yaml"
    bad.write_text("spectrogram:\n  window: 0.5\ndiagnosis:\n  alpah: 0.05\n")
    rc = main(["show", str(tmp_path / "none.zarr"), "--out", str(tmp_path / "out"), "--config", str(bad)])
    err = capsys.readouterr().err.strip()
    assert rc != 0 and "\n" not in err, err
    assert f"{bad}: spectrogram.window: unknown key in section spectrogram" in err, err
    rc = main(["diagnose", str(tmp_path / "none.zarr"), "--out", str(tmp_path / "r.json"), "--config", str(bad)])
    err = capsys.readouterr().err.strip()
    assert rc != 0 and "\n" not in err, err
    assert f"{bad}: diagnosis.alpah: unknown key in section diagnosis" in err, err


def test_generator_command_checks_the_schema_file(tmp_path):
    out = tmp_path / "schema.yaml"
    assert settings.main(["schema", "--out", str(out)]) == 0
    assert settings.main(["schema", "--out", str(out), "--check"]) == 0
    out.write_text(out.read_text() + "# edited by hand\n")
    assert settings.main(["schema", "--out", str(out), "--check"]) == 1


def test_compact_settings_are_the_networks_own_defaults():
    import inspect

    from microdoppler.classifier.models import CompactCNN, CompactSettings

    params = inspect.signature(CompactCNN).parameters
    for key in config_names(CompactSettings):
        want = params[key].default
        got = getattr(CompactSettings(), key)
        assert (list(want) if isinstance(want, tuple) else want) == got, key
