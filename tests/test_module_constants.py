"""Every module-level number of ``microdoppler`` is in a category (issue 57: knobs in
one place; "module constants that are not physical constants become fields or go").

The inventory: each module-level UPPER_CASE name (a leading underscore allowed) of
``src/microdoppler/**/*.py`` bound to a number, a number expression (``1 / SCALE_MIN``,
``1 << 16``) or a tuple of them, read with :mod:`ast` (inside a module-level ``if`` or
``try`` too). Each must be in exactly one of three categories below, with a one-line
reason:

* :data:`PHYSICAL`: physical constants, the paper's stated conventions and other
  fixed conventions (file formats, the 95 % level, a pretrained network's input
  normalisation), which are not settings;
* :data:`IDENTIFIERS`: identifiers and versions (random sub-stream numbers);
* :data:`NOT_YET_FIELDS`: fixed method settings that are not yet fields of a
  settings dataclass, by module: the debt, visible and counted.

A new constant fails :func:`test_every_module_constant_is_in_one_category` until it is
classified (or, better, made a field). ``rotors.fit`` and ``rotors.speed`` hold none
any more: their fixed settings are fields of ``FitConfig`` and ``RotorSpeedConfig``
(``config=False``: no pipeline key sets them); nor do ``causes.config``,
``causes.measure``, ``causes.motor_log`` and ``diagnosis.explain``: the diagnosis's fixed
settings are fields of ``DiagnosisConfig`` (``config=False`` too); nor do
``importing.iqbalance`` (``IQBalanceSettings``), ``rotors.sampling`` and
``datasets.fidelity``, nor, but for physical constants and conventions,
``rotors.order`` and ``rotors.plausibility`` (``OrderConfig``).

Counts (issue 57, at the conversion): 195 constants before; 42 converted to fields
(``rotors.fit`` 24 -> ``FitConfig``, ``rotors.speed`` 18 -> ``RotorSpeedConfig``);
153 remain: 22 physical/convention, 4 identifiers, 127 fixed method settings not yet
fields (``importing.iqbalance``'s 11 among them: it has no settings dataclass). Since:
two conventions of ``rotors.plausibility`` (the error sizes ``setup_testability`` asks
about). The diagnosis: 37 converted to ``DiagnosisConfig`` fields (``causes.config`` 27,
``causes.measure`` 4, ``causes.sideband_fading`` 2, ``diagnosis.explain`` 2,
``causes.motor_log`` 1, ``causes.blade_imbalance`` 1); the twins' and the emulator's
process defaults of ``causes.*`` stay, no diagnosis settings. 118 remain: 24
physical/convention, 4 identifiers, 90 fixed method settings not yet fields. Then 28
more (config=False fields): ``importing.iqbalance`` 11 -> a new ``IQBalanceSettings``,
``rotors.order`` 6 and ``rotors.plausibility`` 3 -> ``OrderConfig``, ``rotors.sampling``
1 -> ``SamplingConfig``, ``datasets.calibration`` 4 -> ``CalibrationConfig``,
``datasets.fidelity`` 3 -> ``FidelityConfig``; the shared helpers' defaults
(``spectra.floor``, ``spectra.lines``, ``stats.bootstrap``, ``io.*``, ``importing.fmcw``,
``importing.plausibility``: no settings class) and ``classifier.training``'s (its
``TrainConfig.to_dict`` is stored in outputs) stay. 90 remain: 24 physical/convention,
4 identifiers, 62 fixed method settings not yet fields.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "microdoppler"

#: physical constants, the paper's and other stated conventions, file-format bounds
PHYSICAL = {
    "classifier.models:IMAGENET_MEAN": "the input normalisation the pretrained ImageNet weights expect",
    "classifier.models:IMAGENET_STD": "the input normalisation the pretrained ImageNet weights expect",
    "causes.blade_imbalance:INTERVAL_LEVEL": "the conventional 95 % interval level",
    "commands.simulate:MAX_AMPLITUDE": "keeps every sample finite in complex64 (the store's I/Q format)",
    "commands.simulate:MAX_MOTOR_HZ": "the flight format's bound on logged speeds (60000 rpm)",
    "emulator.drone:GRAVITY_MPS2": "standard gravity",
    "emulator.profiles:PRF_HZ": "the paper's radar's PRF (~7.3 kHz, 4096 pulses in 0.56 s)",
    "examples:C_MPS": "speed of light",
    "examples:N_FFT": "the paper's STFT length (4096)",
    "examples:SOUND_MPS": "speed of sound in air",
    "importing.flight:SPEED_OF_LIGHT_MPS": "speed of light",
    "importing.fmcw:SPEED_OF_LIGHT_MPS": "speed of light",
    "importing.plausibility:CARRIER_RANGE_HZ": "the radio bands a radar carrier can be in: VHF to the top of mm-wave",
    "importing.plausibility:SPEED_OF_LIGHT_MPS": "speed of light",
    "rotors.order:C_MPS": "speed of light",
    "rotors.plausibility:BLADE_FACTOR": "the blade-count error asked about (2 <-> 3 blades: the rate x 2/3 or 3/2)",
    "rotors.plausibility:TYPO_FACTOR": "the size of a declared field's typo asked about (x2, x0.5)",
    "rotors.order:SOUND_MPS": "speed of sound in air",
    "spectra.spectrogram:C_MPS": "speed of light",
    "spectra.spectrogram:PAPER_DOPPLER_SPAN_MPS": "the paper's image width in radial velocity",
    "spectra.spectrogram:PAPER_WINDOW_S": "the paper's CPI (0.56 s, section II)",
    "stats.bootstrap:LEVEL": "the conventional 95 % interval level",
    "synthesis.model:PHASE_ONE": "fixed-point phase: one revolution = 2**32 (uint32 wraps modulo a turn)",
    "synthesis.radar:SPEED_OF_LIGHT_MPS": "speed of light",
}

#: identifiers and versions
IDENTIFIERS = {
    "causes.body_fluctuation:STREAM": "sub-seed number of the twins' body process",
    "causes.phase_noise:STREAM": "sub-seed number of the twins' phase-noise process",
    "causes.sideband_fading:STREAM": "sub-seed number of the twins' fading process",
    "causes.twins:_BACKGROUND_STREAM": "offset of the background's phase-noise stream from the twin's seed",
}

#: fixed method settings not yet fields of a settings dataclass, by module (the debt: 62
#: in 21 modules; the most in emulator.world 9, emulator.bird 7, synthesis.model 7)
NOT_YET_FIELDS = {
    "causes.body_fluctuation": {
        "BODY_TIMESCALE_S": "the twins' body process's time where a file gives none [s]: no diagnosis setting",
        "BODY_FLUCTUATION_TAU_S": "the emulator's body process's time when not given [s]: no diagnosis setting",
    },
    "causes.phase_noise": {
        "PHASE_NOISE_BANDWIDTH_HZ": "the flat phase noise's bandwidth [Hz]: one for the test's model, twins, emulator",
        "SKIRT_OFFSET_HZ": "the offset the reported skirt_dbc_hz is read at [Hz]: the catalog's unit",
    },
    "causes.sideband_fading": {
        "DEFAULT_FADING_TIMESCALE_S": "the twins' fading time where a file gives none [s]: no diagnosis setting",
    },
    "classifier.training": {
        "EVAL_FORWARD_BATCH": "evaluation's forward chunk (cache; same bits): TrainConfig.to_dict is stored in outputs",
    },
    "commands.simulate": {
        "PROGRESS_MIN_PULSES": "runs longer than this report progress",
        "MAX_PULSES": "largest recording simulate writes (8 GiB of I/Q)",
    },
    "datasets.calibration": {
        "_FFT_BATCH": "CPIs per FFT batch of StftColumns (memory only): it reads a SpectrogramConfig, no own settings",
    },
    "emulator.background": {
        "RANGE_CELL_M": "emulated clutter cell size in range [m]",
        "AZ_CELL_DEG": "emulated clutter cell size in azimuth [deg]",
        "CELL_FADE_S": "cross-fade between clutter cells [s]",
    },
    "emulator.bird": {
        "CONTROL_HZ": "the emulated bird's control rate [Hz]",
        "WING_BELOW_BODY_DB": "emulated wing return below the body's, drawn [dB]",
        "TURN_RATE_SD_RAD_S": "emulated group manoeuvre: turn-rate std, drawn [rad/s]",
        "SPEED_SURGE": "emulated speed surge over the flap-glide cycle, drawn",
        "SCINT_DB": "emulated body scintillation std, drawn [dB]",
        "GLIDE_SHARE": "emulated share of time gliding, drawn",
        "GLIDE_TIME_S": "emulated flap-glide correlation time, drawn [s]",
    },
    "emulator.drone": {
        "CONTROL_HZ": "the emulated drone's control rate [Hz]",
        "MOTOR_TAU_S": "the emulated ESC's first-order lag [s]",
        "PAD_S": "motor history generated beyond the flight's ends [s]",
    },
    "emulator.profiles": {
        "SYSTEMATIC_RANGE_DB": "emulated per-model systematic asymmetry, drawn [dB]",
        "SYSTEMATIC_JITTER_DB": "its per-flight jitter [dB]",
        "AIRFRAMES_PER_MODEL": "airframes per drone model in an emulated world",
        "IMBALANCED_SHARE": "share of a large model's airframes with an unequal blade",
        "IMBALANCE_DB": "range of an unequal blade's imbalance, drawn [dB]",
    },
    "emulator.world": {
        "TRACK_HZ": "the emulated tracker's update rate [Hz]",
        "BLADE_TAPER": "the emulated blade's current taper (thin wires from the hub)",
        "FALLOFF_DB": "large drones' further sideband fall-off per harmonic, drawn [dB]",
        "STRADDLE_LOSS_DB": "largest range-straddle loss [dB]",
        "WEAK_BLADE_SHARE": "share of large-drone flights whose blades echo weakly",
        "WEAK_BLADE_DB": "their first sideband's level below the body, drawn [dB]",
        "MINI_WANDER_M": "the Mini pilot's wander about the plan, drawn [m]",
        "MINI_SCINT_DB": "the Mini's body scintillation std, drawn [dB]",
        "MINI_SCINT_S": "its time scale [s]",
    },
    "examples": {
        "CARRIERS_HZ": "the any-radar generator's carriers",
        "N_SEGMENTS": "scatterer segments per blade of the generator",
        "HUB_FRACTION": "the generator's blade starts at this fraction of its length",
        "VISIBLE_DB": "the generator's visibility rule [dB]",
        "PHASE_GRID": "points per revolution of the generator's Fourier series",
    },
    "importing.fmcw": {
        "DEFAULT_CPI_S": "default CPI of an FMCW import [s]: FmcwParameters is the declared radar, no method settings",
        "VELOCITY_FIT_S": "span of the range-rate fit [s]: no settings class (FmcwParameters is the declared radar)",
    },
    "importing.plausibility": {
        "PRF_RANGE_HZ": "plausible pulse repetition frequencies [Hz]: checks of declared numbers, no settings class",
        "TIP_SPEED_RANGE_MPS": "plausible blade-tip speeds [m/s]: no settings class (rotors.plausibility reads it too)",
        "MAX_TIP_FOLDS": "folds past +-PRF/2 of the slowest tips' Doppler that still pass: no settings class",
    },
    "io.inventory": {
        "MIN_SPLIT_FLIGHTS": "flights of each class a flight-disjoint split needs: a function's default, no settings class",
    },
    "io.motorlog": {
        "PLAUSIBLE_MEDIAN_REV_S": "plausible median flying speed of a rotor [rev/s]: MotorLog is data, no settings class",
        "MAX_REV_S": "absolute ceiling of a logged rotor speed [rev/s]: no settings class",
    },
    "spectra.floor": {
        "FLOOR_WINDOW_BINS": "window of the local noise floor [bins]: local_floor_db's default, shared, no settings class",
        "FLOOR_STEP_BINS": "step of the local noise floor [bins]: local_floor_db's default, no settings class",
        "FLOOR_PERCENTILE": "percentile of the local noise floor: local_floor_db's default, no settings class",
    },
    "spectra.lines": {
        "MAX_HALF_SPACING": "a HERM pair's search half-width / line spacing: helpers of several callers, no settings class",
    },
    "stats.bootstrap": {
        "N_BOOT": "default number of bootstrap replicates: helpers of several callers, no settings class",
    },
    "synthesis.model": {
        "TABLE_SIZE": "entries of the synthesis lookup table",
        "ENVELOPE_SPEED_STEP": "speed grid of the harmonic envelope tables [rev/s]",
        "ENVELOPE_TABLE_SIZE": "angles per harmonic envelope table",
        "ENVELOPE_MAX_BINS": "most speed bins of envelope tables kept at once (memory)",
        "ENVELOPE_SPEED_STRIDE": "a motor's speed is read every this many pulses",
        "SUB_BLOCK": "pulses per lookup sub-block (cache)",
        "CARRIER_STEP": "the track range is evaluated every this many pulses",
    },
    "synthesis.processes": {
        "GAIN_DT_S": "sampling interval of the slow gain processes [s]",
    },
}

#: the fixed settings issue 57 turned into fields, with their former module constants'
#: values: each field's default must be that value, of that type (bit-identical results)
CONVERTED = {
    "rotors.fit": {
        "ITERATIONS": 10,
        "SCREEN_ITERATIONS": 4,
        "TOLERANCE": 1e-5,
        "KEEP": 2,
        "SPREADS_BINS": (0.6, 1.5),
        "BOUND_BINS": 5.0,
        "RESEED": 3,
        "MOVE_PASSES": 2,
        "MOVE_TRIES": 2,
        "COMB_SIMILARITY": 0.45,
        "COMB_SPREAD": 0.5,
        "COMB_SLACK": 0.1,
        "REL_FLOOR": 0.0004,
        "AMBIGUITY_BINS": 5.3,
        "AMBIGUITY_SCALE": 0.13,
        "AMBIGUITY_MAX_BINS": 2.0,
        "AMBIGUITY_ROTOR_BINS": 4.0,
        "AMBIGUITY_ROTOR_SCALE": 0.21,
        "ONE_PAIR_BINS": 4.25,
        "ONE_PAIR_SCALE": 0.8,
        "ONE_PAIR_ROTOR_BINS": 13.0,
        "ONE_PAIR_ROTOR_SCALE": 0.6,
        "BAND_MARGIN": 1.0,
        "BAND_BINS": 16,
    },
    "rotors.speed": {
        "LOG_STEP": 0.005,
        "LINE_PROMINENCE_DB": 6.0,
        "GROUP_RATIO": 1.5,
        "STEP_PENALTY_DB": 0.5,
        "NOISE_DB": 3.0,
        "LINE_RANGE_DB": 30.0,
        "N_FFT_MIN": 4096,
        "N_MEASURE": 4,
        "MIN_SHARE": 0.06,
        "POWER_SHARE_SD": 0.06,
        "SPLIT_COST": 10.0,
        "PATTERN_SD": 0.02,
        "PATTERN_CPIS": 8,
        "SPREAD_SHARE_SD": 0.075,
        "SPREAD_INTERFERENCE_SD": 0.10,
        "REL_FLOOR": 0.008,
        "BLOCK_CPIS": 64,
        "OVERLAP_VARIANCE_FACTOR": 2.0,
    },
    # the diagnosis's fixed settings -> DiagnosisConfig (config=False fields)
    "causes.config": {
        "RAISED_FLOOR_DB": 3.0,
        "ROTATION_RAISED_FLOOR_DB": 30.0,
        "BODY_SEARCH_HZ": 10.0,
        "SCALE_MIN": 0.8,
        "SCALE_MAX": 1 / 0.8,
        "SCALE_STEP": 0.0025,
        "N_MATCH_HARMONICS": 3,
        "MIN_MATCH": 0.2,
        "N_HARMONICS": 5,
        "LINE_HALF_BINS": 4,
        "MIN_PAIR_SNR": 5.0,
        "LAG_STEP_S": 0.01,
        "PN_INNER_HZ": 35.0,
        "PN_OUTER_HZ": 95.0,
        "PN_PROFILE_OUTER_HZ": 1200.0,
        "PN_PROFILE_AGREE_DB": 10.0,
        "PN_PROFILE_BODY_GUARD_HZ": 100.0,
        "PN_PROFILE_FALL_DB": 10.0,
        "PN_BIN_STEP": 2,
        "PN_SMOOTH_CPIS": 2,
        "PN_SMOOTH_BINS": 2,
        "PN_CLUTTER_LINE_HZ": 5.0,
        "LINE_GUARD_FRAC": 0.3,
        "PN_BODY_GUARD_HZ": 40.0,
        "PN_MODEL_GUARD_DB": -10.0,
        "BODY_SMOOTH_CPIS": 9,
        "PN_BODY_SKIRT_HZ": 10.0,
        "PN_CLUTTER_DECAYS_HZ": (),
    },
    "causes.measure": {
        "FINE_DIVISORS": (8, 4, 2),
        "SIDE_FINE_DIVISOR": 2,
        "NON_MULTIPLE_VISIBLE_Z": 3.0,
        "ROTOR_WANDER_REL": 0.025,
    },
    "causes.motor_log": {"LOG_OUTLIER_FRAC": 0.05},
    "causes.sideband_fading": {"COMMON_GAIN_CORR": 0.7, "COMMON_GAIN_BODY_SHARE": 0.5},
    "causes.blade_imbalance": {"N_BOOT": 400},
    "diagnosis.explain": {"LINE_FALSE_ALARM": 0.01, "MODEL_CLEAR_SNR_DB": 10.0},
    # the I/Q balance's fixed settings -> IQBalanceSettings (a new dataclass, config=False fields)
    "importing.iqbalance": {
        "IMAGE_REJECTION_WARN_DB": 30.0,
        "REAL_VALUED_DB": 3.0,
        "DOPPLER_SIGN_WARN_DB": -3.0,
        "RESOLUTION_MARGIN_DB": 6.0,
        "BODY_MIN_BINS": 8,
        "NOTCH_HZ": 20.0,
        "BODY_ACCEPT_DB": 10.0,
        "BODY_LINE_DB": 20.0,
        "BODY_MIN_SEGMENTS": 8,
        "NOISE_MIN_SEGMENTS": 2,
        "NOTCH_EXCESS": 4.0,
    },
    # the order check's (and the set-up's plausibility checks') -> OrderConfig, sub_cpi's -> SamplingConfig
    "rotors.order": {
        "RATIOS": (1 / 3, 1 / 2, 2 / 3, 1.0, 3 / 2, 2.0, 3.0),
        "MAX_CPIS": 64,
        "SCREEN_CPIS": 24,
        "REPORT_AT": 0.01,
        "RERUN_MARGIN": 1.2,
        "RESCUE_TRIES": 3,
    },
    "rotors.plausibility": {"TRACK_SPEED_TOL_MPS": 1.0, "SEGMENT_S": 0.1, "MAX_SEGMENTS": 64},
    "rotors.sampling": {"SUB_CPI_PAD": 16},
    # the calibration's and the fidelity measurement's -> CalibrationConfig, FidelityConfig
    "datasets.calibration": {
        "HIGHPASS_MARGIN_PULSES": 2048,
        "FIT_RUN_CPIS": 4,
        "ALPHA_RECHECK": 3,
        "FINAL_TOL_FRACTION": 4,
    },
    "datasets.fidelity": {"DILATION_STEP": 0.0025, "DILATION_SMOOTH_CPIS": 9, "NONMULTIPLE_MIN_Z": 3.0},
}

#: modules whose every fixed setting is a field (none left in the inventory but physical
#: constants and conventions)
FIELDS_ONLY = (
    "rotors.fit",
    "rotors.speed",
    "causes.config",
    "causes.measure",
    "causes.motor_log",
    "diagnosis.explain",
    "importing.iqbalance",
    "rotors.order",
    "rotors.plausibility",
    "rotors.sampling",
    "datasets.fidelity",
)

_NAME = re.compile(r"^_?[A-Z][A-Z0-9_]*$")


def _numeric(node: ast.AST, top: bool = True) -> bool:
    """Whether ``node`` is a number, a number expression or a tuple of them (a bare
    name or attribute counts only inside an expression: ``1 / SCALE_MIN``, ``2 * np.pi``)."""
    if isinstance(node, ast.Constant):
        return isinstance(node.value, (int, float, complex)) and not isinstance(node.value, bool)
    if isinstance(node, ast.UnaryOp):
        return _numeric(node.operand, top)
    if isinstance(node, ast.BinOp):
        return _numeric(node.left, False) and _numeric(node.right, False)
    if isinstance(node, ast.Name):
        return not top and bool(_NAME.match(node.id))
    if isinstance(node, ast.Attribute):
        return not top and node.attr in ("pi", "e", "inf")
    if isinstance(node, ast.Tuple):
        return bool(node.elts) and all(_numeric(e) for e in node.elts)
    return False


def inventory(root: Path = SRC) -> dict[str, str]:
    """``module:NAME`` -> the value's source, for every module-level UPPER_CASE name
    bound to a number, a number expression or a tuple of them (``module`` relative to
    the package: ``rotors.fit``)."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root).with_suffix("").parts
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        body = list(ast.parse(path.read_text(encoding="utf-8")).body)
        while body:
            st = body.pop(0)
            if isinstance(st, (ast.If, ast.Try)):
                body = [*st.body, *st.orelse, *getattr(st, "finalbody", []), *body]
                continue
            if isinstance(st, ast.Assign):
                targets, value = st.targets, st.value
            elif isinstance(st, ast.AnnAssign) and st.value is not None:
                targets, value = [st.target], st.value
            else:
                continue
            for t in targets:
                if isinstance(t, ast.Name) and _NAME.match(t.id) and _numeric(value):
                    out[f"{module}:{t.id}"] = ast.unparse(value)
    return out


def _not_yet() -> dict[str, str]:
    return {f"{m}:{n}": why for m, names in NOT_YET_FIELDS.items() for n, why in names.items()}


def test_every_module_constant_is_in_one_category():
    """Each constant of the inventory is classified, once; no entry names a constant
    that is gone (make it a field or classify it: the lists at the top of this file)."""
    found = inventory()
    assert len(found) > 50, "the inventory found almost nothing: is SRC right?"
    cats = {"PHYSICAL": PHYSICAL, "IDENTIFIERS": IDENTIFIERS, "NOT_YET_FIELDS": _not_yet()}
    both = [(k, a, b) for a in cats for b in cats if a < b for k in cats[a].keys() & cats[b].keys()]
    assert not both, f"constants in two categories: {both}"
    listed = set().union(*cats.values())
    new = sorted(set(found) - listed)
    assert not new, (
        "module constants in no category (make each a field of its settings dataclass, or add it to "
        f"PHYSICAL, IDENTIFIERS or NOT_YET_FIELDS of tests/test_module_constants.py with a reason): {new}"
    )
    gone = sorted(listed - set(found))
    assert not gone, f"classified constants that are no longer module constants (remove their entries): {gone}"


def test_every_entry_has_a_one_line_reason():
    for key, why in {**PHYSICAL, **IDENTIFIERS, **_not_yet()}.items():
        assert why.strip() and "\n" not in why, key


def test_the_rotor_speed_estimator_fit_and_diagnosis_hold_no_fixed_settings():
    """rotors.fit, rotors.speed, the diagnosis's settings, measurement, motor-log test
    and explanation, the I/Q balance, the order check, the plausibility checks, sub_cpi
    and the fidelity measurement: every fixed setting is a field (FitConfig,
    RotorSpeedConfig, DiagnosisConfig, IQBalanceSettings, OrderConfig, SamplingConfig,
    FidelityConfig); none is left in the not-yet list or the inventory."""
    assert not set(FIELDS_ONLY) & set(NOT_YET_FIELDS)
    left = [k for k in inventory() if k.split(":")[0] in FIELDS_ONLY and k not in PHYSICAL and k not in IDENTIFIERS]
    assert not left, left


@pytest.mark.parametrize("module", sorted(CONVERTED))
def test_the_converted_constants_are_fields_with_their_former_values(module):
    """Each former constant is a field (lower case) whose default is its value, of its
    type, and no longer a module attribute: the results stay bit-identical."""
    import importlib

    from microdoppler.causes.config import DiagnosisConfig
    from microdoppler.configfields import config_names
    from microdoppler.datasets.calibration import CalibrationConfig
    from microdoppler.datasets.fidelity import FidelityConfig
    from microdoppler.importing.iqbalance import IQBalanceSettings
    from microdoppler.rotors.fit import FitConfig
    from microdoppler.rotors.order import OrderConfig
    from microdoppler.rotors.sampling import SamplingConfig
    from microdoppler.rotors.speed import RotorSpeedConfig

    mod = importlib.import_module(f"microdoppler.{module}")
    classes = {
        "rotors.fit": FitConfig,
        "rotors.speed": RotorSpeedConfig,
        "importing.iqbalance": IQBalanceSettings,
        "rotors.order": OrderConfig,
        "rotors.plausibility": OrderConfig,
        "rotors.sampling": SamplingConfig,
        "datasets.calibration": CalibrationConfig,
        "datasets.fidelity": FidelityConfig,
    }
    cls = classes.get(module, DiagnosisConfig)
    cfg = cls()
    for name, value in CONVERTED[module].items():
        assert not hasattr(mod, name), f"{module}.{name} is still a module attribute"
        got = getattr(cfg, name.lower())
        assert got == value and type(got) is type(value), (name, got, value)
        assert name.lower() not in config_names(cls), f"{name.lower()} must be config=False (no pipeline key)"
