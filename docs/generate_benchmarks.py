"""Write the documentation's benchmark page from the records in ``benchmarks/records/``.

No number on the page is typed by hand: every table is read from a record file the
benchmark scripts wrote (JSON or CSV), and each table names its file and, where the
record stores them, the code it ran and its date. The page is rewritten at every docs
build (``docs/conf.py`` calls :func:`write_page`). What each benchmark measures and how
to run it is in ``benchmarks/README.md``.

Usage (also run by ``conf.py``)::

    python docs/generate_benchmarks.py benchmarks/records docs/benchmarks.md
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pandas as pd


def pct(x) -> str:
    """A share as a percentage with one decimal (``0.9513`` -> ``95.1``)."""
    return f"{100 * float(x):.1f}"


def interval(value, lo, hi, *, scale: float = 100.0, digits: int = 1) -> str:
    """``value [lo, hi]`` scaled (percentages by default)."""
    f = f"{{:.{digits}f}}"
    return f"{f.format(scale * value)} [{f.format(scale * lo)}, {f.format(scale * hi)}]"


def table(header, rows) -> str:
    def cell(c) -> str:
        return "" if isinstance(c, float) and c != c else str(c)  # NaN: an empty cell

    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def provenance(name: str, d: dict) -> str:
    """The record's file, code and date as stored (nothing when a field is absent)."""
    parts = [f"record `{name}`"]
    code = d.get("code")
    if isinstance(code, dict):
        code = ", ".join(f"{k} {v}" for k, v in code.items())
    if code:
        parts.append(f"code {code}")
    for key in ("date", "date_utc"):
        if d.get(key):
            parts.append(str(d[key]))
    return "*" + "; ".join(parts) + "*"


def _load(records: Path, pattern: str):
    for path in sorted(records.glob(pattern)):
        yield path.name, json.loads(path.read_text())


def shares(d: dict):
    """Rows for the record's metrics stored as ``{n, count?, share, ci95}``."""
    return [
        (k, v["n"], v.get("count", ""), interval(v["share"], *v["ci95"]))
        for k, v in d.items()
        if isinstance(v, dict) and {"share", "ci95"} <= set(v)
    ]


def paired(d: dict):
    """Rows for the record's paired differences stored as ``{n, before, after, diff, ci95}``."""
    return [
        (k, v["n"], v["before"], v["after"], interval(v["diff"], *v["ci95"], digits=2))
        for k, v in d.items()
        if isinstance(v, dict) and {"diff", "ci95", "before", "after"} <= set(v)
    ]


def rate(v) -> str:
    """A rate stored as ``[value, lo, hi, n]``."""
    return f"{interval(*v[:3])} (n={v[3]})" if v[3] else "–"


def section_any_radar(records: Path) -> list[str]:
    out = [
        "## Rotor speeds on recordings from any radar (`eval_any_radar.py`)",
        "",
        "Recordings drawn by the independent generator (`microdoppler.examples`), estimated with the default "
        "`estimate_rotor_speeds`. Shares in % with 95 % intervals.",
        "",
        "### Pooled over the runs at the current code",
        "",
    ]
    for name, d in _load(records, "pooled_any_radar_*.json"):
        out += [
            f"{d['n_recordings']} recordings"
            + (f", seeds from {d['min_seed']}" if d.get("min_seed") else "")
            + " "
            + provenance(name, d),
            "",
            table(("metric", "n", "count", "share % [95 % CI]"), shares(d)),
            "",
        ]
    rows = []
    for name, d in _load(records, "eval_any_radar_*seed*.json"):
        all_row = next((r for r in d.get("table", []) if r.get("group") == "all"), None)
        if all_row is not None:
            rows.append(
                (
                    f"`{name}`",
                    str(d.get("code", "")).split(" ")[0],
                    all_row["recordings"],
                    all_row["within 2 % (visible)"],
                    all_row["CPIs within 2 sigma (visible)"],
                    f"{d['wall_s']:.0f}" if d.get("wall_s") else "",
                )
            )
    out += [
        "### Each run",
        "",
        table(
            ("record", "code", "recordings", "within 2 % (visible)", "CPIs within 2 sigma (visible)", "wall [s]"), rows
        ),
        "",
    ]
    out += [
        "### Paired comparisons (`compare_any_radar_runs.py`)",
        "",
        "The same recordings before and after a change; differences in points of share, paired bootstrap.",
        "",
    ]
    for name, d in _load(records, "*_paired_any_radar.json"):
        rows = paired(d)
        if rows:
            out += [
                provenance(name, d),
                "",
                table(("metric", "n", "before", "after", "after − before [95 % CI]"), rows),
                "",
            ]
        elif "n_equal" in d:
            out += [
                f"{provenance(name, d)}: {d['n_equal']} of {d['n_recordings']} recordings give the same "
                f"result ({d.get('equal_means', '')})",
                "",
            ]
    return out


def section_rotorspeed(records: Path) -> list[str]:
    out = ["## Rotor speeds on emulated flights (`eval_rotorspeed.py`, `compare_rotorspeed_runs.py`)", ""]
    for name, d in _load(records, "*_paired_seed7.json"):
        lines = d.get("compare") or []
        out += [provenance(name, d) + (f": {lines[0]}" if lines else ""), "", *lines[1:], ""]
    return out


def section_timing(records: Path) -> list[str]:
    rows = []
    for name, d in _load(records, "eval_any_radar_timing_*.json"):
        runs = d.get("runs")
        by_code = {}
        if isinstance(runs, list):
            for r in runs:
                by_code.setdefault(r["code"], []).append(r["cpu_s_per_minute"])
        elif isinstance(runs, dict):
            by_code = {c: [r["cpu_s_per_minute"] for r in rs] for c, rs in runs.items()}
        else:
            by_code = {d.get("code", "?"): d["cpu_s_per_minute"]}
            if "reference" in d:
                by_code[d["reference"]["code"]] = d["reference"]["cpu_s_per_minute"]
        date = d.get("date") or d.get("date_utc", "")
        for code, v in by_code.items():
            rows.append((f"`{name}`", date, code, " / ".join(f"{x:.1f}" for x in v)))
    return [
        "## Rotor-speed estimator cost (`eval_any_radar.py`'s timing run)",
        "",
        "CPU seconds per minute of a 60 s recording (4 rotors, 10 kHz PRF), one core, alternating runs.",
        "",
        table(("record", "date", "code", "CPU s per minute, each run"), rows),
        "",
    ]


def section_diagnosis(records: Path) -> list[str]:
    out = [
        "## The diagnosis on flights with known causes (`eval_diagnosis.py`)",
        "",
        "Rates in % with 95 % flight-bootstrap intervals; ≥36 / <36: flights at or above / below 36 dB body SNR.",
        "",
    ]
    for name, d in _load(records, "eval_diagnosis_*.json"):
        s = d["summary"]
        rows = [
            (
                g,
                v["flights"],
                rate(v["recall"]),
                rate(v["spurious_two"]),
                rate(v["spurious_one"]),
                rate(v["false_alarm"]),
            )
            for g, v in s["overall"].items()
            if g.endswith(("all", "emulator", "independent"))
        ]
        causes = [
            (c, rate(v["recall ≥36 all"]), rate(v["precision ≥36"]), rate(v["recall <36 all"]))
            for c, v in s["per_cause"].items()
        ]
        out += [
            f"### Seed {d['seed']}: `{name}`",
            "",
            provenance(name, d),
            "",
            table(("flights", "n", "recall", "spurious (two causes)", "spurious (one cause)", "false alarm"), rows),
            "",
            table(("cause", "recall ≥36", "precision ≥36", "recall <36"), causes),
            "",
        ]
    return out


def section_extended(records: Path) -> list[str]:
    out = [
        "## What the `extended` twins gain (`eval_extended_gain.py`)",
        "",
        "Per cause's measure: the twins' distance from their flights, `sub_cpi` and `extended`, on flights with "
        "and without the cause (95 % intervals; resolved: the difference's interval excludes 0).",
        "",
    ]
    for name, d in _load(records, "eval_extended_gain_*.json"):
        rows = [
            (
                k,
                v["n"],
                interval(*v["sub_cpi"], scale=1, digits=2),
                interval(*v["extended"], scale=1, digits=2),
                interval(*v["diff"], scale=1, digits=2),
                "yes" if v["resolved"] else "no",
            )
            for k, v in d["summary"].items()
        ]
        out += [
            provenance(name, d),
            "",
            table(("cause, measure, flights", "n", "sub_cpi", "extended", "extended − sub_cpi", "resolved"), rows),
            "",
        ]
    return out


def section_unexplained(records: Path) -> list[str]:
    out = ["## Unequal blades and `unexplained` (`eval_unexplained.py`)", ""]
    for name, d in _load(records, "eval_unexplained_*.json"):
        rows = [(k, rate(v)) for k, v in d["summary"].items() if isinstance(v, list)]
        out += [provenance(name, d), "", table(("measure", "share % [95 % CI]"), rows), ""]
    return out


def section_paper_profile(records: Path) -> list[str]:
    out = ["## The paper profile end to end (`config/paper.yaml`)", ""]
    v = records / "paper_profile_table_v.csv"
    if v.is_file():
        df = pd.read_csv(v)
        rows = [
            (
                r.trainset,
                r.n_seeds,
                interval(r.accuracy_mean, r.accuracy_ci95_low, r.accuracy_ci95_high, scale=1),
                r.paper_accuracy,
                r.drone_recall,
                r.bird_recall,
            )
            for r in df.itertuples()
        ]
        out += [
            "Table V: " + f"*record `{v.name}`*",
            "",
            table(("training set", "seeds", "accuracy % [95 % CI]", "paper", "drone recall", "bird recall"), rows),
            "",
        ]
    vi = records / "paper_profile_table_vi.csv"
    if vi.is_file():
        df = pd.read_csv(vi)
        cols = [c[:-5] for c in df.columns if c.endswith("_mean")]
        rows = [(r["variant"], r["n_flights"], *(f"{r[c + '_mean']:.2f}" for c in cols)) for _, r in df.iterrows()]
        out += [
            "Table VI (distance of the twins from their flights, means): " + f"*record `{vi.name}`*",
            "",
            table(("variant", "flights", *cols), rows),
            "",
        ]
    for name, d in _load(records, "paper_profile_diagnosis.json"):
        out += [
            f"Diagnosis, flights per first cause: *record `{name}`*, {d.get('source', '')}",
            "",
            table(("cause", "flights"), sorted(d["counts"].items(), key=lambda kv: -kv[1])),
            "",
        ]
    return out


def _wilson_share(count: int, n: int, ci) -> str:
    return f"{count} of {n}" + (
        f" ({pct(count / n)} % [{pct(ci[0])}, {pct(ci[1])}])" if n and ci[0] is not None else ""
    )


def section_imbalance_bounds(records: Path) -> list[str]:
    """``eval_imbalance_bounds.py``: the share of named weak blades whose interval holds
    the truth, and the one-sided bounds, per band of true imbalance."""
    out = []
    for name, d in _load(records, "eval_imbalance_bounds_*.json"):
        h = d["held_of_named"]
        rows = [
            (
                band,
                v["n"],
                _wilson_share(v["named"], v["n"], v["named_wilson95"]),
                _wilson_share(v["held_of_named"], v["named"], v["held_wilson95"]),
                _wilson_share(v["one_sided_lower"], v["named"], v["one_sided_wilson95"]),
            )
            for band, v in d["by_band"].items()
        ]
        out += [
            f"### Seed {d['seed']}: `{name}`",
            "",
            provenance(name, d)
            + f"; {d['n']} flights of {d['duration_s']:g} s; interval holds the truth on "
            + _wilson_share(h["count"], h["n"], h["wilson95"])
            + " of the named",
            "",
            table(("true imbalance", "flights", "named", "interval holds the truth", "one-sided (lower)"), rows),
            "",
        ]
    return (
        (["## Weak-blade sizes and their bounds (`eval_imbalance_bounds.py`)", "", "Wilson 95 % intervals.", ""] + out)
        if out
        else []
    )


def section_rotor_uncertainty(records: Path) -> list[str]:
    """``eval_rotor_uncertainty.py``: recording means within 2 sigma, per method."""
    out = []
    for name, d in _load(records, "eval_rotor_uncertainty_*.json"):
        rows = [
            (
                method,
                v["n_recordings"],
                v["n_ranks"],
                _wilson_share(v["within_2_mean_sigma"]["count"], v["n_ranks"], v["within_2_mean_sigma"]["wilson95"]),
                _wilson_share(v["within_2_naive_sigma"]["count"], v["n_ranks"], v["within_2_naive_sigma"]["wilson95"]),
                _wilson_share(
                    v["recordings_all_ranks_within_2_mean_sigma"]["count"],
                    v["n_recordings"],
                    v["recordings_all_ranks_within_2_mean_sigma"]["wilson95"],
                ),
            )
            for method, v in d["summary"].items()
        ]
        out += [
            f"### Seed {d['seed']}: `{name}`",
            "",
            provenance(name, d)
            + f"; {d['n_recordings']} recordings of {d['duration_s']:g} s, {d['n_no_estimate']} without an estimate; "
            f"the printed method is the stored one on {d['printed_method_is_stored']} of {d['n_recordings']}",
            "",
            table(
                (
                    "method",
                    "recordings",
                    "rotor ranks",
                    "within 2 mean sigma",
                    "within 2 naive sigma",
                    "recordings with every rank within",
                ),
                rows,
            ),
            "",
        ]
    return (
        (
            [
                "## A recording's mean rotor speed and its sigma (`eval_rotor_uncertainty.py`)",
                "",
                "Wilson 95 % intervals.",
                "",
            ]
            + out
        )
        if out
        else []
    )


def section_wrong_setups(records: Path) -> list[str]:
    """``eval_wrong_setups.py``: wrong declared set-ups refused at import per field, and
    (``--diagnose``) what the diagnosis reads on the ones the import accepted."""
    out = []
    for name, d in _load(records, "eval_wrong_setups_*.json"):
        out += [
            f"### Seed {d['seed']}: `{name}`",
            "",
            provenance(name, d) + f"; recordings of {d['duration_s']:g} s",
            "",
        ]
        for mode, m in d["summary"].items():
            w = m["wrong"]
            rows = [
                (kind, _wilson_share(v["refused_naming_field"], v["n"], v["wilson95"]))
                for kind, v in m["per_wrong_field"].items()
            ]
            out += [
                f"Import `{mode}`: wrong set-ups refused naming the field "
                + _wilson_share(w["refused_naming_field"], w["n"], w["wilson95"])
                + f"; right set-ups refused {m['right']['false_refusals']} of {m['right']['n']}.",
                "",
                table(("wrong field", "refused naming it"), rows),
                "",
            ]
            dg = m.get("diagnosis")
            if dg:
                n_wrong = sum(dg["wrong_outcomes"].values())
                out += [
                    "What became of the wrong set-ups (refused at import, or what the diagnosis read); "
                    f"read `none`: {_wilson_share(dg['wrong_read_none'], n_wrong, dg['wrong_read_none_wilson95'])}. "
                    f"The right set-ups' diagnoses: "
                    + ", ".join(f"{c} {k}" for c, k in dg["right_causes"].items())
                    + ".",
                    "",
                    table(("outcome", "wrong set-ups"), sorted(dg["wrong_outcomes"].items(), key=lambda kv: -kv[1])),
                    "",
                ]
    return (
        (["## Wrongly declared set-ups (`eval_wrong_setups.py`)", "", "Wilson 95 % intervals.", ""] + out)
        if out
        else []
    )


def section_two_sided(records: Path) -> list[str]:
    """``eval_two_sided.py``: the wrong set-ups the import accepted that read ``none``,
    and the right set-ups of the same recordings, diagnosed by one version of the code."""
    out = []
    for name, d in _load(records, "eval_two_sided_*.json"):
        s = d["summary"]
        rows = [
            (k[: -len("_wrong")], "; ".join(v["causes"]) or "none", v.get("reason") or "")
            for k, v in d["stores"].items()
            if k.endswith("_wrong")
        ]
        out += [
            f"### `{name}`",
            "",
            provenance(name, d) + f"; recordings of {d['duration_s']:g} s: {d['recordings']}",
            "",
            f"Wrong set-ups reading `none`: {s['wrong_read_none']} of {s['wrong']}; right set-ups `unexplained`: "
            f"{s['right_unexplained']} of {s['right_diagnosed']} diagnosed, by the two-sided check "
            f"{s['right_two_sided']}.",
            "",
            table(("recording", "diagnosis of the wrong set-up", "two-sided reason"), rows),
            "",
        ]
    return (["## The goodness of fit both ways (`eval_two_sided.py`)", ""] + out) if out else []


def section_campaign(records: Path) -> list[str]:
    """A campaign of one's own, end to end (``benchmarks/eval_campaign.py``): per record,
    which acceptance checks hold, Table VI's ``nonmultiple_db`` rows, Table V where
    the campaign has birds, and per flight the true and the diagnosed weak blade."""
    out = []
    for name, d in _load(records, "eval_campaign_*.json"):
        a = d.get("args", {})
        n_drones = len(d.get("flights", []))
        n_birds = int(a.get("birds", 0) or 0)
        out += [
            f"### Campaign: {n_drones} {a.get('mode', 'stand')} drone recordings"
            + (f" and {n_birds} birds" if n_birds else "")
            + f", {d['carrier_hz'] / 1e9:.2f} GHz, PRF {d['prf_hz']:.0f} Hz, {a.get('duration_s')} s each",
            "",
            provenance(name, d) + f"; pipeline {d.get('pipeline_s')} s, exit status {d.get('exit_status')}",
            "",
            table(("check", "holds"), [(k, "yes" if v else "**no**") for k, v in d.get("acceptance", {}).items()]),
            "",
            "Table VI, `nonmultiple_db` (distance to the measurement, dB; 95 % flight-bootstrap interval):",
            "",
            table(
                ("variant", "flights", "mean [interval]", "resolved"),
                [
                    (
                        v,
                        "" if r.get("n_flights") is None else int(r["n_flights"]),
                        ""
                        if r.get("nonmultiple_db_mean") is None
                        else interval(
                            r["nonmultiple_db_mean"],
                            r["nonmultiple_db_ci95_low"],
                            r["nonmultiple_db_ci95_high"],
                            scale=1.0,
                            digits=2,
                        ),
                        "" if r.get("nonmultiple_db_resolved") is None else r["nonmultiple_db_resolved"],
                    )
                    for v, r in d.get("table_vi_nonmultiple_db", {}).items()
                ],
            ),
            "",
        ]
        if d.get("table_v"):
            out += [
                "Table V, accuracy [%] over seeds (95 % interval):",
                "",
                table(
                    ("training set", "seeds", "accuracy [interval]"),
                    [
                        (
                            r["trainset"],
                            r["n_seeds"],
                            interval(r["accuracy_mean"], r["accuracy_ci95_low"], r["accuracy_ci95_high"], scale=1.0),
                        )
                        for r in d["table_v"]
                    ],
                ),
                "",
            ]
        out += [
            "Per drone flight: the true weak blade, what the diagnosis named, the split's SNR line:",
            "",
            table(
                ("flight", "true imbalance [dB]", "diagnosis", "named imbalance [dB]", "SNR line"),
                [
                    (
                        f["flight_id"],
                        f"{f['imbalance_db']:.1f}" if f["imbalance_db"] else "–",
                        f.get("diagnosis") or "",
                        "" if f.get("named_imbalance_db") is None else f"{f['named_imbalance_db']:.1f}",
                        f.get("split_snr_line", "body"),
                    )
                    for f in d.get("flights", [])
                ],
            ),
            "",
        ]
    return (["## A campaign of one's own, end to end", ""] + out) if out else []


def write_campaign(records: Path, path: Path) -> Path:
    """Write :func:`section_campaign`'s tables, without its heading, to ``path`` for the
    campaign page (only when they changed)."""
    text = "\n".join(section_campaign(Path(records))[2:]) or "No campaign record yet.\n"
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)
    return path


def section_rule_times(records: Path) -> list[str]:
    """The pipeline's per-rule times, one column per recorded run (``rule_times_*.csv``
    written by ``benchmarks/rule_times.py --record``), oldest first, and the ratio of the
    newest to the oldest."""
    runs = []
    for path in sorted(records.glob("rule_times_default_*.csv")):
        meta_path = path.with_suffix(".json")
        meta = json.loads(meta_path.read_text()) if meta_path.exists() else {}
        runs.append((path.name, meta, pd.read_csv(path).set_index("rule")))
    if not runs:
        return []
    runs.sort(key=lambda r: str(r[1].get("date_utc", "")))
    rules = list(dict.fromkeys(r for _, _, t in reversed(runs) for r in t.index if r != "all")) + ["all"]
    first, last = runs[0][2], runs[-1][2]

    def cell(t, rule):
        if rule not in t.index:
            return ""
        return f"{t.loc[rule, 'total_s']:.0f} ({int(t.loc[rule, 'jobs'])})"

    rows = []
    for rule in rules:
        ratio = ""
        if rule in first.index and rule in last.index and first.loc[rule, "total_s"] > 0:
            ratio = f"{last.loc[rule, 'total_s'] / first.loc[rule, 'total_s']:.2f}"
        rows.append((f"`{rule}`", *(cell(t, rule) for _, _, t in runs), ratio))
    walls = [m.get("wall_s") for _, m, _ in runs]
    wall_ratio = f"{walls[-1] / walls[0]:.2f}" if walls[0] and walls[-1] else ""
    rows.append(("**wall clock of the run**", *(f"{w:.0f}" if w else "" for w in walls), wall_ratio))
    header = ("rule", *(f"{m.get('commit', n)} s (jobs)" for n, m, _ in runs), "newest / oldest")
    return [
        "## Pipeline run time per rule (`rule_times.py`)",
        "",
        "Snakemake's benchmark files of a `snakemake --cores 2` run of the embedded default on a quiet 2-core "
        "machine, rolled per rule (rule `report_rule_times`): the summed wall-clock seconds of the rule's jobs "
        "(busy time; jobs ran two at a time) and the number of jobs, per recorded run (the column names its "
        "commit; a blank cell: the rule did not exist or wrote no benchmark file in that run), and the wall "
        "clock from the first job's start to the last one's end. Records: "
        + ", ".join(f"`{n}` ({m.get('date_utc', '')})" for n, m, _ in runs)
        + ".",
        "",
        table(header, rows),
        "",
    ]


def section_rule_times_paper(records: Path) -> list[str]:
    """Per-rule times of (possibly partial) paper-profile runs (``rule_times_paper_*``)."""
    out = []
    for path in sorted(records.glob("rule_times_paper_*.csv")):
        meta_path = path.with_suffix(".json")
        meta = json.loads(meta_path.read_text()) if meta_path.exists() else {}
        t = pd.read_csv(path)
        rows = [
            (f"`{r.rule}`", int(r.jobs), f"{r.total_s:.0f}", f"{r.max_s:.0f}", f"{r.peak_rss_mib:.0f}")
            for r in t.itertuples()
        ]
        out += [
            f"### Paper profile, code {meta.get('commit', '?')} (record `{path.name}`)",
            "",
            "`snakemake --cores 2 --configfile config/paper.yaml` from an empty `results/`"
            + (f"; {meta['partial']}" if meta.get("partial") else "")
            + ".",
            "",
            table(("rule", "jobs", "total s", "longest job s", "peak memory MiB"), rows),
            "",
        ]
    return out


SECTIONS = (
    section_rule_times,
    section_rule_times_paper,
    section_any_radar,
    section_rotorspeed,
    section_timing,
    section_diagnosis,
    section_extended,
    section_unexplained,
    section_paper_profile,
    section_imbalance_bounds,
    section_rotor_uncertainty,
    section_wrong_setups,
    section_two_sided,
    section_campaign,
)


def render(records: Path) -> str:
    """The page's Markdown from the records in ``records``."""
    records = Path(records)
    lines = [
        "# Benchmark results",
        "",
        "Rendered from the record files in `benchmarks/records/` at every build of these pages "
        "(`docs/generate_benchmarks.py`): no number here is typed by hand. What each benchmark measures and "
        "how to run it is in `benchmarks/README.md`; the decisions the numbers led to are in "
        "[experiments](experiments.md). Intervals are 95 % flight-bootstrap intervals "
        "(`microdoppler.stats.bootstrap`) unless a table says otherwise.",
        "",
    ]
    for section in SECTIONS:
        lines += section(records)
    return "\n".join(lines)


def write_page(records: Path, page: Path) -> Path:
    """Write :func:`render`'s page to ``page`` (only when it changed)."""
    page = Path(page)
    text = render(records)
    if not page.is_file() or page.read_text() != text:
        page.write_text(text)
    return page


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: python docs/generate_benchmarks.py RECORDS_DIR PAGE.md")
    print(write_page(Path(sys.argv[1]), Path(sys.argv[2])))
