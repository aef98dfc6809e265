"""The diagnosis from files in to report out.

:func:`diagnose_flight` runs the four steps on one flight, each once and in turn:
:func:`.measure.measure` (the flight against the paper's model of it, one
:class:`~.measure.Measurements`), :func:`.hypotheses.run_tests` (one held-out test
per cause), :func:`.decide.decide_flight` (the causes named, the report entry) and
:func:`.explain.plot_diagnosis` (the figure). :func:`diagnose` does it for many
flight stores and writes the report (``diagnosis-report/2``, every flight in it:
``skipped`` with the reason where it cannot be diagnosed); the pipeline's rules call
:func:`diagnose_split`, :func:`aggregate_report` and :func:`write_twin_extensions`
(the ``extended`` variant's extensions, :mod:`.aggregate`).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..configfields import config_names, knob
from ..errors import ConfigError, InputError
from ..io.flightzarr import read_flight
from ..io.motorlog import MotorLog
from ..io.outputs import atomic_file
from ..rotors.plausibility import setup_testability
from ..causes.catalog import UNEXPLAINED, catalog
from ..causes.extensions import save_extensions
from .aggregate import aggregate, aggregate_twins
from .config import DiagnosisConfig, unknown_key_error
from .decide import decide_flight, skipped_entry, tests_given
from .explain import goodness_of_fit, plot_diagnosis
from .hypotheses import run_tests
from .measure import Undiagnosable, measure

#: the report format written by :func:`diagnose` (``shared/formats/flight-zarr.md``)
REPORT_SCHEMA = "diagnosis-report/2"


def diagnose_flight(flight, *, motor_log: MotorLog | None = None, config=None, figure_path=None) -> dict:
    """Diagnose one measured drone flight: measure, test, decide, explain.

    Parameters
    ----------
    flight : microdoppler.io.Flight
        A measured drone flight (``target == "drone"``) of at least 20 CPIs (about
        6 s at 7.3 kHz) with ``background_iq``.
    motor_log : MotorLog, optional
        Its motor log; default the store's ``motors/*`` arrays.
    config : DiagnosisConfig or dict, optional
        Settings (default: ``DiagnosisConfig()``).
    figure_path : path, optional
        Where to write the figure (measured vs baseline vs extended, residual).

    Returns
    -------
    dict
        The report entry (``diagnosis-report/2``, ``decide.decide_flight``):
        flight_id, cause (the first of ``causes`` or ``"none"``), causes (every
        significant and relevant cause, strongest first, each with its extension,
        held-out gain with the other named causes in both models, and evidence) and
        the flight's evidence (every test against the paper's model, the greedy
        steps, the calibration).

    Raises
    ------
    Undiagnosable
        (an :class:`~microdoppler.errors.InputError` naming the field) when the flight
        cannot be diagnosed (``measure.check_diagnosable``: a bird, a Mini, no usable
        motor log, too short), or no rotor line is visible (``hypotheses.check_testable``).

    See Also
    --------
    diagnose, aggregate, DiagnosisConfig

    Examples
    --------
    A 6 s emulated Inspire 2 without any cause of the catalog:

    >>> from microdoppler.emulator import FlightSpec, emulate_flight
    >>> flight, _ = emulate_flight(FlightSpec("demo", "drone", drone_model="inspire2", duration_s=6.0,
    ...                                       mean_range_m=600.0, path="straight", snr_db=40.0, seed=1))
    >>> from microdoppler.diagnosis import diagnose_flight
    >>> entry = diagnose_flight(flight, config={"figures": False})
    >>> entry["flight_id"], entry["cause"], entry["causes"]
    ('demo', 'none', [])
    >>> "motor_speed_scale" in entry["evidence"]["tests"]
    True
    """
    cfg = config if isinstance(config, DiagnosisConfig) else DiagnosisConfig.from_dict(config)
    started = time.perf_counter()
    M = measure(flight, motor_log, cfg)
    T = run_tests(M, cfg)
    D = decide_flight(M, T, cfg, started=started)
    gof = goodness_of_fit(flight, M, D, cfg)
    entry = explained_entry(D.entry, gof, T)
    # the declared set-up's fields no check on this recording could see off by a typo
    entry["setup_not_testable"] = setup_testability(
        flight, float(np.median(M.f_log_hz)), log_independent=not M.log_from_radar
    )
    if figure_path is not None and cfg.figures:
        plot_diagnosis(flight, M, D, figure_path, cfg, gof=gof)
    return entry


def explained_entry(entry: dict, gof: dict, T) -> dict:
    """The report entry with what the named causes leave: ``unexplained`` appended to
    ``causes`` (with ``excess_db`` and ``band_hz``) when the goodness of fit finds an
    excess, and ``not_testable`` ({cause: reason}) for the causes the flight's data
    could not test, so that ``none`` is never read as "tested and absent"."""
    out = dict(entry)
    causes = list(out["causes"])
    # a test that found a gain common to the body and the blades (the fading's)
    fading = next((t for t in T.tests.values() if "common_gain_db" in t.evidence), None)
    common = (
        fading is not None
        and fading.testable
        and "common_gain_db" in fading.evidence
        and fading.log_e >= entry["evidence"]["log_evalue_threshold"]
    )
    if gof["excess"]:
        causes.append(
            {
                "cause": UNEXPLAINED,
                "params": {"excess_db": gof["excess_db"], "band_hz": gof["band_hz"]},
                "evidence": {k: v for k, v in gof.items() if not k.startswith("_")},
                # a line where the other has none: the direction and the fields to check
                **({"reason": gof["missing_reason"]} if gof.get("missing_reason") else {}),
            }
        )
    elif common:
        # a significant gain common to the body and the blades (range-cell straddle,
        # aspect): no catalog cause is a gain on the whole target
        span = gof["analysed_band_hz"]
        causes.append(
            {
                "cause": UNEXPLAINED,
                "params": {"excess_db": fading.evidence["common_gain_db"], "band_hz": span},
                "evidence": {
                    "kind": "a power fluctuation common to the body and the blades",
                    "std_db": fading.evidence["common_gain_db"],
                    "body_correlation": fading.evidence.get("body_correlation"),
                    "body_share": fading.evidence.get("body_share"),
                    "log_evalue": fading.log_e,
                },
            }
        )
    out["causes"] = causes
    out["cause"] = causes[0]["cause"] if causes else "none"
    # with the named causes in both models (a sideband cause may be testable only
    # with a named phase-noise skirt in the floor's model)
    given = tests_given(T, [c["cause"] for c in entry["causes"]])
    out["not_testable"] = {c: str(t.evidence.get("reason", "not testable")) for c, t in given.items() if not t.testable}
    out["evidence"] = {**out["evidence"], "goodness_of_fit": {k: v for k, v in gof.items() if not k.startswith("_")}}
    return out


def write_json(obj, path) -> Path:
    """Write ``obj`` as JSON, atomically (:func:`microdoppler.io.outputs.atomic_file`)."""
    with atomic_file(path) as tmp:
        tmp.write_text(json.dumps(obj, indent=1))
    return Path(path)


#: columns of the one-row-per-flight table written beside the report (:func:`report_table`)
TABLE_COLUMNS = (
    "flight_id",
    "cause",
    "causes",
    "params",
    "intervals",
    "log_evalues",
    "not_testable",
    "setup_not_testable",
    "goodness_of_fit",
    "excess_db",
    "band_hz",
    "reason",
    "hint",
    "plausibility_warnings",
)
#: hints for a skip reason: what the user can do about it
SKIP_HINTS = {
    "no motor log": "import the recording with `microdoppler import --estimate-motors` to estimate its rotor "
    "speeds from the radar (pipeline: measurements.estimate_missing_motor_logs: true), or give "
    "its log with --motor-log",
}


def table_path(out_json) -> Path:
    """The table written beside the report: ``report.json`` -> ``report.csv``."""
    return Path(out_json).with_suffix(".csv")


def skip_hint(reason: str | None, flight=None) -> str:
    """What to do about a skip ``reason`` ("" where there is no hint). With the
    ``flight``: where its import already tried to estimate the rotor speeds from the
    radar and found none (``attrs.motors_estimate_failed``), the hint says so and
    points at the declared set-up (at the fields its plausibility warnings name)."""
    failed = None if flight is None else flight.attrs.get("motors_estimate_failed")
    if str(reason or "") == "no motor log" and failed:
        doubt = plausibility_warnings(flight)
        fields = doubt[0].split(":", 1)[0].strip() if doubt else "prf_hz, carrier_hz, n_blades, blade_length_m"
        return (
            f"the import's rotor-speed estimate found none ({failed}): check the declared {fields} and import "
            "again, or give the log with --motor-log"
        )
    return SKIP_HINTS.get(str(reason or ""), "")


def plausibility_warnings(flight) -> list[str]:
    """The warnings a ``--force`` import stored with the set-up it found implausible."""
    w = flight.attrs.get("plausibility_warnings") or []
    return [str(x) for x in w] if isinstance(w, list) else [str(w)]


def _flat(x) -> str:
    return json.dumps(x, separators=(",", ":"), sort_keys=False)


def report_row(entry: dict, *, warnings=(), hint: str | None = None) -> dict:
    """One report entry as a row of :data:`TABLE_COLUMNS`: the causes (``;``), each
    cause's parameters (compact JSON ``{cause: params}``), the intervals the data
    allow them (``{cause: {param: {low, high, bound, level, meaning}}}``, where the
    cause's test gives one) and log e-value, the causes
    not testable (``cause: reason``, ``;``), the goodness of fit (``explained`` or
    ``excess``, its worst band's level and band), the skip reason with its hint, and the
    import's plausibility warnings (``warnings``); ``hint`` replaces the skip reason's
    generic hint (:func:`skip_hint` with the flight)."""
    causes = entry.get("causes") or []
    gof = (entry.get("evidence") or {}).get("goodness_of_fit") or {}
    skipped = entry.get("cause") == "skipped"
    return {
        "flight_id": entry["flight_id"],
        "cause": entry["cause"],
        "causes": ";".join(c["cause"] for c in causes),
        "params": _flat({c["cause"]: (c.get("extension") or c).get("params") for c in causes}) if causes else "",
        "intervals": _flat(
            {c["cause"]: c["evidence"]["intervals"] for c in causes if "intervals" in (c.get("evidence") or {})}
        )
        if causes
        else "",
        "log_evalues": ";".join(
            f"{c['cause']}={c['evidence']['log_evalue']}" for c in causes if "log_evalue" in (c.get("evidence") or {})
        ),
        "not_testable": ";".join(f"{k}: {v}" for k, v in (entry.get("not_testable") or {}).items()),
        "setup_not_testable": ";".join(f"{k}: {v}" for k, v in (entry.get("setup_not_testable") or {}).items()),
        "goodness_of_fit": "" if skipped or not gof else ("excess" if gof.get("excess") else "explained"),
        "excess_db": "" if gof.get("excess_db") is None else gof["excess_db"],
        "band_hz": "" if gof.get("band_hz") is None else _flat(gof["band_hz"]),
        "reason": entry.get("reason", ""),
        "hint": (hint if hint is not None else skip_hint(entry.get("reason"))) if skipped else "",
        "plausibility_warnings": ";".join(warnings),
    }


def write_table(rows: list[dict], path) -> Path:
    """Write ``rows`` (:func:`report_row`) as CSV, atomically."""
    import csv
    import io

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=TABLE_COLUMNS, lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    with atomic_file(path) as tmp:
        tmp.write_text(buf.getvalue())
    return Path(path)


def diagnose(paths, out_json, *, motor_logs: dict | None = None, config=None, figures_dir=None, log=print) -> dict:
    """Diagnose the flights at ``paths`` and write the report JSON (``diagnosis-report/2``)
    and, beside it, the one-row-per-flight table (``report.csv``: ``table_path``, ``report_row``).

    Every flight appears in the report: flights that cannot be diagnosed (birds,
    target-free recordings, Minis, drones without a usable motor log, too short, no
    visible rotor lines) with cause ``skipped`` and the ``reason``. A store that
    breaks the format is an error. A store's stored plausibility warnings (an import
    with ``--force``) are repeated in the log and the table.

    Parameters
    ----------
    paths : iterable of path-like
        flight-zarr/1 stores.
    out_json : path-like
        The report to write (atomically).
    motor_logs : dict, optional
        ``{flight_id: MotorLog}``, overriding the stores' own logs.
    config : DiagnosisConfig or dict, optional
        Settings (default: ``DiagnosisConfig()``).
    figures_dir : path-like, optional
        Where to write one figure per diagnosed flight.
    log : callable
        Progress messages (one string each).

    Returns
    -------
    dict
        The report (``schema``, ``settings``, ``flights``: one entry per store).

    Raises
    ------
    microdoppler.errors.InputError
        When a store breaks the flight-zarr/1 format.

    See Also
    --------
    diagnose_flight, aggregate

    Examples
    --------
    >>> import json, tempfile
    >>> from pathlib import Path
    >>> from microdoppler.diagnosis import diagnose
    >>> from microdoppler.emulator import FlightSpec, emulate_flight
    >>> from microdoppler.io import write_flight
    >>> folder = Path(tempfile.mkdtemp())
    >>> bird, _ = emulate_flight(FlightSpec("b1", "bird", bird_kind="single", duration_s=1.0, seed=2))
    >>> report = diagnose([write_flight(folder / "b1.zarr", bird)], folder / "report.json", log=lambda m: None)
    >>> [(e["flight_id"], e["cause"]) for e in report["flights"]]
    [('b1', 'skipped')]
    >>> json.loads((folder / "report.json").read_text())["flights"][0]["reason"]
    'bird flight: no rotors'
    """
    cfg = config if isinstance(config, DiagnosisConfig) else DiagnosisConfig.from_dict(config)
    entries, rows = [], []
    for p in paths:
        e, row, lines = _diagnose_store(p, motor_logs or {}, cfg, figures_dir)
        for line in lines:
            log(line)
        entries.append(e)
        rows.append(row)
    report = {"schema": REPORT_SCHEMA, "catalog": list(catalog()), "flights": entries}
    write_json(report, out_json)
    write_table(rows, table_path(out_json))
    return report


def _diagnose_store(path, motor_logs: dict, cfg, figures_dir) -> tuple[dict, dict, list[str]]:
    """One store of :func:`diagnose`: (report entry, table row, log lines)."""
    f = read_flight(path)
    ml = motor_logs.get(f.flight_id)
    fig = Path(figures_dir) / f"{f.flight_id}.png" if figures_dir else None
    warns = plausibility_warnings(f)
    lines = [f"{f.flight_id}: warning: imported despite an implausible set-up: {w}" for w in warns]
    hint = None
    try:
        e = diagnose_flight(f, motor_log=ml, config=cfg, figure_path=fig)
    except Undiagnosable as exc:
        e = skipped_entry(f.flight_id, exc.reason)
        hint = skip_hint(exc.reason, f)
        lines.append(f"{f.flight_id}: skipped: {exc.reason}" + (f" (hint: {hint})" if hint else ""))
    else:
        named = (
            "; ".join(
                f"{c['cause']} {(c.get('extension') or c).get('params')}"
                + (f" ({c['reason']})" if c.get("reason") else "")
                for c in e["causes"]
            )
            or "none"
        )
        untested = e.get("setup_not_testable") or {}
        lines.append(
            f"{f.flight_id}: {named} ({e['evidence']['seconds']:.1f} s)"
            + (f"; not testable from this recording: {', '.join(untested)} (setup_not_testable)" if untested else "")
        )
    return e, report_row(e, warnings=warns, hint=hint), lines


# ---------------------------------------------------------------- the pipeline's rules

#: the split's sets (``results/splits/flights.csv``)
SETS = ("train", "validation", "test")


@dataclass(frozen=True)
class DiagnosisRuns:
    """The diagnosis keys the workflow reads (which flights, how many jobs); the rest
    are :class:`DiagnosisConfig`'s (:func:`split_settings` checks them all)."""

    sets: list[str] = knob(
        description="Split sets whose measured drone flights are diagnosed; in results/diagnosis/extended.yaml each "
        "of their twins carries its own flight's causes (per_flight mode). Twins of flights outside these sets draw "
        "causes from the population.",
        default_factory=lambda: list(SETS),
        items={"type": "string", "enum": list(SETS)},
    )
    population_sets: list[str] = knob(
        description="Split sets (a subset of sets) whose diagnoses form the per-model population of extended.yaml "
        "and the extensions/1 median aggregate. Default train only: no validation or test flight shapes a training "
        "twin.",
        default_factory=lambda: ["train"],
        items={"type": "string", "enum": list(SETS)},
    )
    min_fraction: float = knob(
        0.25,
        "For the extensions/1 median aggregate only (microdoppler.diagnosis.aggregate.aggregate): a cause is kept "
        "when named for at least this fraction of the diagnosed flights. The pipeline's extended.yaml "
        "(extensions/2) keeps every flight's own causes and does not use it.",
        minimum=0,
        maximum=1,
    )
    flight_batches: int = knob(
        2,
        "Jobs the diagnosed flights are dealt to in turn (rule diagnose_flights, one job per batch, side by side; "
        "rule report_diagnosis gathers them into one report). 2 keeps both cores of a laptop busy; more on a "
        "cluster. The report is the same for any number.",
        minimum=1,
    )


#: the keys of the ``diagnosis:`` section that are not DiagnosisConfig fields
PIPELINE_KEYS = tuple(config_names(DiagnosisRuns))


def split_settings(settings: dict | None, *, source="config") -> tuple[dict, DiagnosisConfig]:
    """The ``diagnosis:`` section of a config: ``({"sets", "population_sets",
    "min_fraction", "flight_batches"}, DiagnosisConfig)``.

    ``sets`` (split sets whose drone flights are diagnosed, each twin then carrying its
    own flight's causes; default every set), ``population_sets`` (sets whose diagnoses
    form the per-model population and the extensions/1 median; default ``[train]``, so
    no validation or test flight shapes a training twin; a subset of ``sets``) and
    ``min_fraction`` (default 0.25) and ``flight_batches`` (jobs the diagnosed flights
    are dealt to, side by side; default 2) are the pipeline's keys; every other key is a
    :class:`DiagnosisConfig` field. An invalid value raises :class:`ConfigError`
    ``<source>: diagnosis.<key>: <problem> (expected ...)``.
    """
    if settings is None:
        settings = {}
    if not isinstance(settings, dict):
        raise ConfigError(source, "diagnosis", f"is a {type(settings).__name__}", "a mapping of diagnosis settings")
    s = dict(settings)
    names = [*PIPELINE_KEYS, *config_names(DiagnosisConfig)]  # the fixed settings are no keys
    for k in s:
        if k not in names:
            raise unknown_key_error(source, k, names)
    sets = _sets(s.pop("sets", list(SETS)), "sets", source)
    pop = _sets(s.pop("population_sets", ["train"]), "population_sets", source)
    for i, x in enumerate(pop):
        if x not in sets:
            raise ConfigError(
                source,
                f"diagnosis.population_sets[{i}]",
                f"is {x!r}, which is not diagnosed",
                f"a set of diagnosis.sets ({', '.join(sets)})",
            )
    mf = s.pop("min_fraction", 0.25)
    if isinstance(mf, bool) or not isinstance(mf, (int, float)) or not 0 <= float(mf) <= 1:
        raise ConfigError(source, "diagnosis.min_fraction", f"is {mf!r}", "a number in [0, 1]")
    nb = s.pop("flight_batches", 2)
    if isinstance(nb, bool) or not isinstance(nb, int) or nb < 1:
        raise ConfigError(source, "diagnosis.flight_batches", f"is {nb!r}", "an integer >= 1")
    return (
        {"sets": sets, "population_sets": pop, "min_fraction": float(mf), "flight_batches": nb},
        DiagnosisConfig.from_dict(s, source=source),
    )


def _sets(sets, key: str, source) -> list:
    if isinstance(sets, (str, bytes)) or not isinstance(sets, (list, tuple)) or not sets:
        raise ConfigError(
            source, f"diagnosis.{key}", f"is {sets!r}", f"a non-empty list of split sets from {list(SETS)}"
        )
    for i, x in enumerate(sets):
        if x not in SETS:
            raise ConfigError(source, f"diagnosis.{key}[{i}]", f"is {x!r}", f"one of {', '.join(SETS)}")
    return list(dict.fromkeys(sets))


def _training_drones(split_csv, sets) -> pd.DataFrame:
    df = pd.read_csv(split_csv)
    for col in ("flight_id", "set", "target"):
        if col not in df.columns:
            raise InputError(split_csv, col, "column missing", "flight_id, set, target columns")
    return df[(df["target"] == "drone") & df["set"].isin(sets)]


def diagnose_split(
    measured_dir, logs_zarr, split_csv, out_json, figures_dir, *, settings=None, log=print, part=None
) -> dict:
    """Diagnose the drone flights of ``settings['sets']`` (default: every set) with
    :func:`diagnose`, using their ingested motor logs (or the stores' own);
    flights that cannot be diagnosed (no usable log, Minis, ...) are listed as
    ``skipped`` with the reason. ``part`` = (index, n): only every n-th of those
    flights from the index-th on (the pipeline's ``diagnosis.flight_batches`` jobs;
    :func:`merge_reports` gathers them into the report of all)."""
    from ..io.inventory import read_ingested_log

    pipe, cfg = split_settings(settings)
    Path(figures_dir).mkdir(parents=True, exist_ok=True)
    fids = diagnosed_flights(split_csv, pipe["sets"])
    if part is not None:
        index, n = (int(x) for x in part)
        fids = fids[index::n]
    logs = {}
    if Path(logs_zarr).exists():
        logs = {fid: ml for fid in fids if (ml := read_ingested_log(logs_zarr, fid)) is not None}
    return diagnose(
        [Path(measured_dir) / f"{fid}.zarr" for fid in fids],
        out_json,
        motor_logs=logs,
        config=cfg,
        figures_dir=figures_dir,
        log=log,
    )


def diagnosed_flights(split_csv, sets) -> list[str]:
    """The drone flights of the split's ``sets``, in the split table's order."""
    return [str(f) for f in _training_drones(split_csv, sets)["flight_id"]]


def merge_reports(reports, split_csv, out_json, figure_dirs=(), figures_out=None, *, settings=None) -> dict:
    """Gather the reports of :func:`diagnose_split`'s parts (``reports``: their JSON
    files, each with its table beside it) into one report of every diagnosed flight,
    in the split table's order (the report and table one job over all flights
    writes), and their figures (``figure_dirs``) into ``figures_out``.

    Raises
    ------
    microdoppler.errors.InputError
        When a part's report is not a diagnosis report, or a flight is in none or
        in two of them.
    """
    import csv
    import shutil

    pipe, _ = split_settings(settings)
    entries, rows = {}, {}
    for path in map(Path, reports):
        try:
            part = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise InputError(path, "file", f"cannot be read as JSON ({type(exc).__name__})", REPORT_SCHEMA) from None
        if part.get("schema") != REPORT_SCHEMA:
            raise InputError(path, "schema", f"is {part.get('schema')!r}", REPORT_SCHEMA)
        with open(table_path(path), newline="") as fh:
            table = {r["flight_id"]: r for r in csv.DictReader(fh)}
        for e in part["flights"]:
            fid = e["flight_id"]
            if fid in entries:
                raise InputError(path, f"flights/{fid}", "is in two parts", "each flight in one part")
            entries[fid], rows[fid] = e, table[fid]
    fids = diagnosed_flights(split_csv, pipe["sets"])
    missing = [f for f in fids if f not in entries]
    if missing:
        raise InputError(out_json, "flights", f"{', '.join(missing)} in no part", "every diagnosed flight in one part")
    report = {"schema": REPORT_SCHEMA, "catalog": list(catalog()), "flights": [entries[f] for f in fids]}
    write_json(report, out_json)
    write_table([rows[f] for f in fids], table_path(out_json))
    if figures_out is not None:
        Path(figures_out).mkdir(parents=True, exist_ok=True)
        for d in map(Path, figure_dirs):
            for png in sorted(d.glob("*.png")):
                shutil.copyfile(png, Path(figures_out) / png.name)
    return report


def aggregate_report(report_json, split_csv, out_yaml, *, settings=None):
    """extensions/1 (median aggregate) from the report's flights in
    ``settings['population_sets']``."""
    pipe, _ = split_settings(settings)
    report = json.loads(Path(report_json).read_text())
    ids = set(_training_drones(split_csv, pipe["population_sets"])["flight_id"])
    ext = aggregate(report, min_fraction=pipe["min_fraction"], flight_ids=ids)
    save_extensions(ext, out_yaml)
    return ext


def write_twin_extensions(report_json, split_csv, out_yaml, *, settings=None, mode: str = "per_flight"):
    """``extended.yaml`` (``extensions/2``) from the report's flights in the split sets
    of ``settings['sets']`` (the ``diagnosis:`` config section), the population from
    those of ``settings['population_sets']``; drone models from the split table.
    Returns the :class:`~microdoppler.causes.twins.TwinExtensions`."""
    from ..causes.twins import TwinExtensions, save_twin_extensions

    pipe, _ = split_settings(settings)
    try:
        report = json.loads(Path(report_json).read_text())
    except (OSError, ValueError) as exc:
        raise InputError(
            report_json, "file", f"cannot be read as JSON ({type(exc).__name__})", "a diagnosis-report/2 JSON file"
        ) from None
    drones = _training_drones(split_csv, pipe["sets"])
    models = dict(zip(drones["flight_id"].astype(str), drones.get("drone_model", [""] * len(drones))))
    pop_ids = set(_training_drones(split_csv, pipe["population_sets"])["flight_id"].astype(str))
    ext = aggregate_twins(report, models, flight_ids=set(models), population_ids=pop_ids, mode=mode, source=report_json)
    ext = TwinExtensions(
        ext.flights,
        ext.population,
        ext.mode,
        {**ext.meta, "sets": list(pipe["sets"]), "population_sets": list(pipe["population_sets"])},
    )
    save_twin_extensions(ext, out_yaml)
    return ext
