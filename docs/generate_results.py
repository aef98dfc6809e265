"""Write the documentation's results page from a pipeline run's own files.

No number on the results page is typed by hand: every table is read from the CSV
files the pipeline wrote (``results/reports/``), every figure is copied from its PNG,
and the diagnosis summary is counted from ``results/diagnosis/report.json``. The page
is rewritten at every docs build (``docs/conf.py`` calls :func:`write_page`), so it
cannot drift from the run it names.

Usage (also run by ``conf.py``)::

    python docs/generate_results.py results docs/results.md docs/_static/results
"""

from __future__ import annotations

import json
import shutil
import sys
from collections import Counter
from pathlib import Path

import pandas as pd

# (file under results/, title, what it shows, columns kept (None: all), float digits)
TABLES = [
    (
        "reports/table_iii.csv",
        "Table III: composition of the sets",
        "Flights and 20-timestep images per set and class, with the body SNR.",
        None,
        1,
    ),
    (
        "reports/table_v.csv",
        "Table V: classifier results",
        "Mean over the classifier seeds with the flight-bootstrap intervals, per training set.",
        None,
        1,
    ),
    (
        "reports/table_iv.csv",
        "Table IV: calibrated simulation parameters",
        "Per variant, drone model and radar: S_body, S_blade and alpha as fitted on the measured flights.",
        None,
        3,
    ),
    (
        "reports/table_vi.csv",
        "Table VI: fidelity of the twins",
        "Distance of each variant's twins from their measured flights on held-out CPIs (flight-bootstrap 95 % "
        "intervals; `resolved` marks a paired difference whose interval excludes zero).",
        None,
        2,
    ),
    (
        "reports/rule_times.csv",
        "Per-rule times",
        "Per rule of the run: its jobs, their summed and longest wall-clock seconds, summed CPU seconds and "
        "the largest peak memory of a job [MiB], rolled from Snakemake's benchmark files by rule "
        "`report_rule_times`; `all` sums every job (busy time: the run's wall clock is shorter where jobs ran "
        "side by side). `benchmarks/rule_times.py` compares it with a recorded run.",
        None,
        1,
    ),
]
# (glob under results/, title)
FIGURES = [
    ("reports/confusion_real.png", "Fig. 6: confusion matrix of the real-trained classifier"),
    ("reports/fig12_boxplot.png", "Fig. 12: accuracy and recalls over seeds, per training set"),
    ("reports/fig_fidelity.png", "Fidelity of the twins (Table VI)"),
    ("figures/fig2_herm_lines.png", "Fig. 2: HERM lines of eq. (1)"),
    ("figures/fig8_sampling.png", "Fig. 8: motor-speed sampling"),
    ("figures/twins_*.png", "Measured flights and their twins (Fig. 9/10)"),
]


def _markdown_table(df: pd.DataFrame, digits: int) -> str:
    def cell(v):
        if isinstance(v, float):
            return "" if pd.isna(v) else f"{v:.{digits}f}"
        return str(v)

    head = "| " + " | ".join(str(c) for c in df.columns) + " |"
    rule = "|" + "|".join("---" for _ in df.columns) + "|"
    rows = ["| " + " | ".join(cell(v) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join([head, rule, *rows])


def _diagnosis_summary(report_json: Path) -> str:
    report = json.loads(report_json.read_text())
    flights = report.get("flights", [])
    first = Counter(f.get("cause", "?") for f in flights)
    every = Counter(c.get("cause", "?") for f in flights for c in f.get("causes", []))
    df = pd.DataFrame(
        [
            {"cause": k, "flights (first cause)": first.get(k, 0), "flights (any position)": every.get(k, 0)}
            for k in sorted(set(first) | set(every))
        ]
    )
    return f"{len(flights)} flights in `{report_json.name}` ({report.get('schema', '?')}).\n\n" + _markdown_table(df, 0)


def write_page(results: Path, page: Path, static: Path) -> Path:
    """Write ``page`` (MyST Markdown) from the run in ``results``; figures are copied to
    ``static`` (a folder under the docs' ``_static``). A missing run gives a page that
    says so and how to make one."""
    results = Path(results)
    lines = ["# Results", ""]
    if not (results / "reports").is_dir():
        lines += [
            f"No pipeline run was found at `{results}`. Run `snakemake --cores 2` (or set "
            "`MICRODOPPLER_RESULTS` to a run's `results/` folder) and build the docs again.",
            "",
        ]
        page.write_text("\n".join(lines))
        return page
    lines += [
        f"Generated from the pipeline run in `{results}` by `docs/generate_results.py`: every table "
        "below is that run's CSV file, every figure its PNG. Rebuild the docs after a run to update it.",
        "",
    ]
    for rel, title, what, cols, digits in TABLES:
        f = results / rel
        if not f.exists():
            continue
        df = pd.read_csv(f)
        if cols:
            df = df[[c for c in cols if c in df.columns]]
        lines += [f"## {title}", "", f"{what} Source: `results/{rel}`.", "", _markdown_table(df, digits), ""]
    report = results / "diagnosis" / "report.json"
    if report.exists():
        lines += [
            "## Diagnosis summary",
            "",
            "Causes named per flight (see [the diagnosis](diagnosis.md)). Source: `results/diagnosis/report.json`.",
            "",
            _diagnosis_summary(report),
            "",
        ]
    if static.exists():
        shutil.rmtree(static)
    static.mkdir(parents=True)
    figs = []
    for pattern, title in FIGURES:
        for src in sorted(results.glob(pattern)):
            dst = static / src.name
            shutil.copyfile(src, dst)
            figs += [
                f"### {title}: `{src.name}`" if "*" in pattern else f"### {title}",
                "",
                f"![{title}](_static/results/{src.name})",
                "",
            ]
    if figs:
        lines += ["## Figures", "", *figs]
    page.write_text("\n".join(lines))
    return page


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit("usage: generate_results.py RESULTS_DIR PAGE.md STATIC_DIR")
    print(write_page(Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])))
