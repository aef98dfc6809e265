"""The docs pages generated at build: the benchmark page renders the numbers of the
records in ``benchmarks/records/`` (not numbers typed by hand), and the report page's
cause table is the catalog's."""

import importlib.util
import json
import re
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
RECORDS = ROOT / "benchmarks" / "records"


def _docs_module(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / "docs" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_benchmark_page_shows_the_records_numbers():
    page = _docs_module("generate_benchmarks").render(RECORDS)
    pooled = json.loads((RECORDS / "pooled_any_radar_holdouts.json").read_text())
    m = pooled["within 2 % (visible)"]
    row = (
        f"| within 2 % (visible) | {m['n']} | {m['count']} | {100 * m['share']:.1f} "
        f"[{100 * m['ci95'][0]:.1f}, {100 * m['ci95'][1]:.1f}] |"
    )
    assert row in page
    diag = json.loads((RECORDS / "eval_diagnosis_seed20261126.json").read_text())
    recall, lo, hi, n = diag["summary"]["overall"]["≥36 all"]["recall"]
    assert f"{100 * recall:.1f} [{100 * lo:.1f}, {100 * hi:.1f}] (n={n})" in page
    table_v = pd.read_csv(RECORDS / "paper_profile_table_v.csv").set_index("trainset")
    real = table_v.loc["real"]
    acc = f"{real.accuracy_mean:.1f} [{real.accuracy_ci95_low:.1f}, {real.accuracy_ci95_high:.1f}]"
    assert f"| real | 9 | {acc} |" in page


def test_benchmark_page_names_every_json_record_it_reads():
    page = _docs_module("generate_benchmarks").render(RECORDS)
    named = set(re.findall(r"`([\w.]+\.(?:json|csv))`", page))
    skipped = {p.name for p in RECORDS.glob("eval_any_radar_*.json")} - named
    # the any-radar runs without a table (joined or re-run subsets) and their CSV twins are not shown
    assert {p.name for p in RECORDS.glob("*_paired_*.json")} <= named
    assert {p.name for p in RECORDS.glob("eval_diagnosis_*.json")} <= named
    assert {p.name for p in RECORDS.glob("eval_two_sided_*.json")} <= named
    assert "eval_any_radar_seed1000.json" not in skipped


def test_report_page_cause_table_is_the_catalogs():
    from microdoppler.causes.catalog import CAUSES

    text = _docs_module("generate_catalog").causes_table()
    for cause in CAUSES.values():
        assert f"`{cause.name}`" in text
        for p in cause.params:
            assert f"`{p.name}` | {p.unit} |" in text


def test_benchmark_page_shows_the_recorded_rule_times():
    page = _docs_module("generate_benchmarks").render(RECORDS)
    records = sorted(RECORDS.glob("rule_times_default_*.csv"))
    assert records, "no per-rule time record"
    for path in records:
        assert f"`{path.name}`" in page
        table = pd.read_csv(path).set_index("rule")
        assert f"{table.loc['all', 'total_s']:.0f} ({int(table.loc['all', 'jobs'])})" in page
        wall = json.loads(path.with_suffix(".json").read_text())["wall_s"]
        assert f"| {wall:.0f} |" in page or f"| {wall:.0f}" in page
    for path in RECORDS.glob("rule_times_paper_*.csv"):
        top = pd.read_csv(path).iloc[0]
        assert f"`{path.name}`" in page and f"| `{top.rule}` | {int(top.jobs)} | {top.total_s:.0f} |" in page


def test_results_page_shows_a_runs_rule_times(tmp_path):
    """The docs' results page carries the run's per-rule table (rule report_rule_times)."""
    reports = tmp_path / "results" / "reports"
    reports.mkdir(parents=True)
    pd.DataFrame(
        {
            "rule": ["train_classifier", "all"],
            "jobs": [6, 6],
            "total_s": [260.14, 260.14],
            "max_s": [45.0, 45.0],
            "cpu_s": [90.6, 90.6],
            "peak_rss_mib": [498.2, 498.2],
        }
    ).to_csv(reports / "rule_times.csv", index=False)
    page = _docs_module("generate_results").write_page(tmp_path / "results", tmp_path / "results.md", tmp_path / "s")
    text = page.read_text()
    assert "## Per-rule times" in text and "| train_classifier | 6 | 260.1 | 45.0 | 90.6 | 498.2 |" in text


def test_pipeline_page_config_table_is_the_settings_classes():
    from microdoppler.settings import SECTIONS, config_table

    text = _docs_module("generate_config").config_table()
    assert text == config_table()
    for name, section in SECTIONS.items():
        assert f"| **{name}** |" in text
        for key in section.keys():
            assert f"| `{key}` |" in text, f"{name}.{key}"
    page = (ROOT / "docs" / "pipeline.md").read_text()
    assert "```{include} _include/config.inc\n```" in page
    assert "| key | meaning |" not in page  # no table typed by hand beside it
