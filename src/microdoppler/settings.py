"""The pipeline's configuration: every section and key, defined once.

Each section of ``config/config.yaml`` is one or more settings dataclasses whose
fields are made by :func:`microdoppler.configfields.knob` (default, description,
range). The library's own classes define the sections they read
(:class:`~microdoppler.spectra.spectrogram.SpectrogramSettings` is ``spectrogram``,
:class:`~microdoppler.classifier.training.TrainConfig` most of ``classifier``,
:class:`~microdoppler.datasets.calibration.CalibrationConfig` is
``datasets.calibration``, :class:`~microdoppler.datasets.fidelity.FidelityConfig`
part of ``fidelity``, :class:`~microdoppler.diagnosis.DiagnosisConfig` most of
``diagnosis``); the keys only the workflow reads are the small classes below.
:data:`SECTIONS` puts them together, and from it come:

- the JSON schema ``workflow/schemas/config.schema.yaml`` (:func:`schema_yaml`),
  which the pipeline validates the config with (``workflow/rules/common.smk``);
  every section accepts only its own keys;
- the table of keys in the docs (:func:`config_table`, ``docs/pipeline.md``).

``python -m microdoppler.settings schema`` writes the schema, ``... table`` prints
the table; ``--check`` exits 1 when the committed schema differs from the definitions.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from .causes.config import DiagnosisConfig
from .classifier.models import CompactSettings
from .classifier.training import ClassifierRuns, TrainConfig
from .configfields import check_keys, config_names, fields_schema, knob
from .datasets.calibration import CalibrationConfig
from .datasets.fidelity import FidelityConfig, FidelityReport
from .datasets.speeds import FixedSpeedsSampling, SubCpiSampling
from .diagnosis.pipeline import DiagnosisRuns
from .errors import check_config_keys
from .rotors.sampling import VARIANTS
from .spectra.spectrogram import SpectrogramSettings

#: the schema file the pipeline validates its config with
SCHEMA_PATH = Path("workflow") / "schemas" / "config.schema.yaml"


# ---------------------------------------------------------------- workflow-only keys


@dataclass(frozen=True)
class Measurements:
    """Where the measured flights come from (config ``measurements:``)."""

    source: str = knob(
        "emulator",
        "'emulator' generates measured flights with the measurement emulator; 'directory' reads flight-zarr/1 "
        "stores from `directory`.",
        enum=["emulator", "directory"],
    )
    directory: str = knob("", "Folder of <flight_id>.zarr stores (source 'directory').")
    motor_logs_table: str = knob(
        "",
        "TSV mapping flight_id to motor_log (path), format (ulog|csv), unit (rpm|rev/s|rad/s), time_offset_s, for "
        "flights whose store holds no log. Empty: the emulator's exported table.",
    )
    estimate_missing_motor_logs: bool = knob(
        False,
        "Drone flights with no motor log (in the store or the table): estimate each rotor's speed from the HERM "
        "lines (microdoppler.rotors.speed) and use it as the flight's log (status 'estimated', motors_source radar); "
        "a flight with no visible sideband pair stays 'skipped' with the reason.",
    )


@dataclass(frozen=True)
class Emulator:
    """Measurement emulator settings (config ``emulator:``)."""

    profile: str = knob(
        "default",
        "World profile: 'default' (small, the whole pipeline in 15 minutes), 'paper' (Table III sizes), or 'test' "
        "(tiny, CI).",
    )
    seed: int = knob(20261121, "Seed of the emulated world.")


def _variant(cls, description: str) -> dict:
    """The schema of one variant's settings (no default: a variant not given uses the
    library's defaults, and ``extended`` then ``sub_cpi``'s settings)."""
    props = fields_schema(cls) if cls else {}
    return {"description": description, "type": "object", "properties": props, "additionalProperties": False}


#: ``sampling.per_variant``: each variant's own settings
PER_VARIANT = {
    "sub_cpi": _variant(SubCpiSampling, "Sub-CPI sampling of every rotor's logged speed."),
    "per_cpi": _variant(None, "One value per CPI (a spline of the log): no settings."),
    "single_motor": _variant(SubCpiSampling, "As sub_cpi, for one rotor (motor 0) only."),
    "fixed_speeds": _variant(FixedSpeedsSampling, "One speed for every rotor and the whole flight."),
    "extended": _variant(SubCpiSampling, "The extended variant's sub-CPI sampling; not given: sub_cpi's settings."),
}


@dataclass(frozen=True)
class Sampling:
    """Motor-speed sampling variants (config ``sampling:``)."""

    variants: list[str] = knob(
        description="Variants to build (sub_cpi, per_cpi, single_motor, fixed_speeds, extended).",
        default_factory=lambda: ["sub_cpi", "per_cpi", "single_motor", "fixed_speeds"],
        items={"type": "string", "enum": [*VARIANTS, "extended"]},
    )
    n_fft: int = knob(4096, "CPI length [pulses].", minimum=16)
    seed: int = knob(7, "Seed for per-flight random choices (rolling-average window, fixed speed).")
    per_variant: dict = knob(
        description="Settings of each variant; editing one reruns only that variant's chain. sub_cpi/single_motor: "
        "per_cpi (decimated samples per CPI), window_pulses_min/max (rolling-average window drawn per flight, paper "
        "1500-3000); fixed_speeds: spread (relative half-width around the model's typical speed).",
        default_factory=dict,
        schema={"properties": PER_VARIANT, "additionalProperties": False},
    )


@dataclass(frozen=True)
class Figures:
    """Figure settings (config ``figures:``)."""

    ulog: str = knob(
        "../shared/data/motor-logs/px4_esc_status.ulg", "PX4 ULog with per-motor esc_status speeds for Fig. 2c."
    )


@dataclass(frozen=True)
class Fractions:
    """Target shares of the split (config ``datasets.split.fractions``)."""

    train: float = knob(0.6, "Training share.", minimum=0, maximum=1)
    test: float = knob(0.3, "Test share.", minimum=0, maximum=1)
    validation: float = knob(0.1, "Validation share.", minimum=0, maximum=1)


@dataclass(frozen=True)
class Split:
    """The flight-disjoint split (config ``datasets.split``)."""

    seed: int = knob(20221, "Seed of the random flight orders tried.")
    fractions: Fractions = knob(
        Fractions(),
        "Target share of each class's images per set (paper 60:30:10).",
        schema={"required": ["train", "test", "validation"]},
    )
    n_trials: int = knob(500, "Random flight orders tried per class; the closest to the shares wins.", minimum=1)


@dataclass(frozen=True)
class Extended:
    """How the ``extended`` variant picks its extensions (config ``datasets.extended``)."""

    mode: str = knob(
        "per_flight",
        "per_flight: each twin gets the causes and parameters diagnosed on its own measured flight (none for a "
        "flight with no cause or a skipped one: the twin equals its sub_cpi twin); twins of flights outside the "
        "diagnosed sets draw from the population. population: every twin draws each cause of its drone model with "
        "the cause's incidence among that model's diagnosed flights and the parameters of one of the flights that "
        "named it (seeded by sampling.seed and the flight).",
        enum=["per_flight", "population"],
    )


@dataclass(frozen=True)
class Datasets:
    """Dataset settings (config ``datasets:``)."""

    split: Split = knob(Split(), "Flight-disjoint split of the measured flights by class (paper §III.C).")
    snr_search_hz: float = knob(
        10.0,
        "Search half-width around the expected line Doppler for the SNR measure [Hz]; also the base half-width of "
        "the sideband windows.",
        exclusive_minimum=0,
    )
    calibration: CalibrationConfig = knob(
        CalibrationConfig(), "Per-flight fit of the twins' alpha, S_body and S_blade (paper §V.B, Table IV)."
    )
    extensions: str = knob(
        "results/diagnosis/extended.yaml",
        "Model extensions of the 'extended' variant: YAML written by rule aggregate_extensions (extensions/2: "
        "per-flight causes and their per-model population, microdoppler.datasets.extended), or an extensions/1 file "
        "(one set for every twin).",
    )
    extended: Extended = knob(Extended(), "How the 'extended' variant picks each twin's model extensions.")
    figure_timesteps: int = knob(
        100,
        "Timesteps shown in the measured-vs-twin figures (100 is about 56 s, as the paper's Fig. 10).",
        minimum=1,
    )
    flight_batches: int = knob(
        1,
        "Flight batches of the per-flight stages: with N > 1, synthesize_flights and inject_background run once per "
        "(variant, batch), each on the flights whose stable id hash (CRC32 modulo N, "
        "microdoppler.datasets.batches.flight_batch) falls in its batch, so a cluster runs them side by side; rule "
        "merge_flight_batches gathers each variant's batches into results/injected/{variant}.zarr and "
        "results/reports/table_iv_{variant}.csv. A twin's seed depends on its flight only, so every twin is the "
        "same for every N. 1 (default): one job per variant, as few jobs as possible on one machine.",
        minimum=1,
    )


# ---------------------------------------------------------------- the sections


@dataclass(frozen=True)
class Section:
    """One section of the config: its description and the settings classes whose
    configuration fields are its keys (in order); ``defaults`` are the pipeline's
    defaults where they differ from a class's own."""

    name: str
    description: str
    classes: tuple
    defaults: dict = field(default_factory=dict)

    def properties(self) -> dict:
        props = {}
        for cls in self.classes:
            props.update(fields_schema(cls, self.defaults))
        return props

    def keys(self) -> list[str]:
        return [k for cls in self.classes for k in config_names(cls)]

    def check(self, mapping, source="config") -> dict:
        """``mapping`` when each of its keys is one of the section's; else a one-line
        :class:`~microdoppler.errors.ConfigError` naming the key and the section."""
        return check_keys(mapping, self.keys(), self.name, source)


SECTIONS = {
    s.name: s
    for s in (
        Section("measurements", "Where the measured flights come from.", (Measurements,)),
        Section("emulator", "Measurement emulator settings.", (Emulator,)),
        Section("sampling", "Motor-speed sampling variants (paper §V.A.1).", (Sampling,)),
        Section(
            "spectrogram",
            "Spectrogram and tile settings (paper §II, §III.C) in physical units, resolved for the radar of the "
            "measured flights (their median PRF and carrier; microdoppler.datasets.imaging). The CPI comes from "
            "window_s or n_fft (not both); the image's Doppler width from one of doppler_span_hz, doppler_span_mps, "
            "blade_tip_rev_s, n_bins. With none given: the CPI is the power of two nearest 0.56 s x PRF and the "
            "image spans 95 m/s (±47.5 m/s), which for the paper's radar (7.3 kHz, 1.35 GHz) is 4096 pulses and 480 "
            "bins.",
            (SpectrogramSettings,),
        ),
        Section("figures", "Figure settings.", (Figures,)),
        Section("datasets", "Dataset settings.", (Datasets,)),
        Section(
            "classifier",
            "Bird/drone classifier (paper §IV, §V.C). Defaults are for the compact CNN trained from scratch on 2 CPU "
            "cores; the paper's values (pretrained AlexNet, FC layers only) are learning_rate 1.5e-4, momentum 0.98, "
            "weight_decay 2e-4, batch_size 16, lr_step_epochs 10, lr_gamma 0.1, exceed_limit 10 with no epoch cap.",
            (ClassifierRuns, TrainConfig),
            # the pipeline's defaults where TrainConfig's differ: its own keep the paper's best
            # epoch, and its empty compact mapping means CompactCNN's defaults, written out here
            defaults={"average_last_epochs": 4, "compact": CompactSettings()},
        ),
        Section(
            "diagnosis",
            "Diagnosis settings: which flights are diagnosed and in how many jobs, then the fields of "
            "microdoppler.diagnosis.DiagnosisConfig (their physical meaning in its docstring); the fixed settings "
            "are its fields that are no configuration keys (config=False), and a key that names one is an error.",
            (DiagnosisRuns, DiagnosisConfig),
        ),
        Section(
            "fidelity",
            "Direct twin fidelity (Table VI, rule report_fidelity): twin vs measured flight per feature on the "
            "calibration's held-out CPIs. Visible pairs and harmonics follow datasets.calibration (visible_db, "
            "n_harmonics), the line search datasets.snr_search_hz.",
            (FidelityConfig, FidelityReport),
        ),
    )
}
#: sections a config must have (the others default to their keys' defaults)
REQUIRED = ["measurements", "emulator", "sampling", "spectrogram"]


def config_schema() -> dict:
    """The JSON schema of the pipeline's config (draft 2020-12): every key with its
    description, type, range and default; no section accepts a key it does not define."""
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "description": "Configuration of the microdoppler pipeline (config/config.yaml).",
        "type": "object",
        "properties": {
            name: {
                "description": s.description,
                "type": "object",
                "default": {},
                "properties": s.properties(),
                "additionalProperties": False,
            }
            for name, s in SECTIONS.items()
        },
        "required": list(REQUIRED),
        "additionalProperties": False,
    }


HEADER = (
    "# Generated by `python -m microdoppler.settings schema` from the settings classes\n"
    "# (microdoppler.settings.SECTIONS): edit those, not this file.\n"
)


def schema_yaml() -> str:
    """:func:`config_schema` as the text of ``workflow/schemas/config.schema.yaml``."""
    return HEADER + yaml.safe_dump(config_schema(), sort_keys=False, allow_unicode=True, width=120)


def defaults() -> dict:
    """The config every key at its default (what validation fills in)."""
    out = {}
    for name, s in SECTIONS.items():
        out[name] = {k: v["default"] for k, v in s.properties().items()}
    return out


def check_config(config: dict, source="config") -> None:
    """Reject a key of ``config`` that no section defines, in one line
    (:func:`microdoppler.errors.check_config_keys` against :func:`config_schema`)."""
    check_config_keys(config, config_schema(), source=source)


def _cell(value) -> str:
    return str(value).replace("|", "\\|").replace("\n", " ").replace("<", "&lt;").replace(">", "&gt;")


def _default_text(value) -> str:
    if value is _NOT_GIVEN:
        return "–"
    if value == "":
        return '`""`'
    return "`" + yaml.safe_dump(value, default_flow_style=True, width=10**6).strip().removesuffix("...").strip() + "`"


_NOT_GIVEN = object()


def config_table() -> str:
    """The docs' table of every key (Markdown): key (dotted below nested mappings),
    default (–: none, a variant's settings that are not given) and meaning, under a
    row per section."""
    rows = ["| key | default | meaning |", "|---|---|---|"]

    def walk(props, prefix):
        for k, e in props.items():
            default = _default_text(e.get("default", _NOT_GIVEN))
            rows.append(f"| `{prefix}{k}` | {_cell(default)} | {_cell(e['description'])} |")
            if "properties" in e:
                walk(e["properties"], f"{prefix}{k}.")

    for name, s in SECTIONS.items():
        rows.append(f"| **{name}** | | {_cell(s.description)} |")
        walk(s.properties(), "")
    return "\n".join(rows) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m microdoppler.settings", description=__doc__.split("\n\n")[0])
    p.add_argument("what", choices=["schema", "table"], help="write the schema, or print the docs' table of keys")
    p.add_argument("--out", default=str(SCHEMA_PATH), help="schema file (default: %(default)s)")
    p.add_argument("--check", action="store_true", help="exit 1 when the schema file is not the generated one")
    args = p.parse_args(argv)
    if args.what == "table":
        sys.stdout.write(config_table())
        return 0
    text, out = schema_yaml(), Path(args.out)
    if args.check:
        same = out.is_file() and out.read_text() == text
        if not same:
            print(
                f"{out}: differs from the settings classes; run python -m microdoppler.settings schema", file=sys.stderr
            )
        return 0 if same else 1
    out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
