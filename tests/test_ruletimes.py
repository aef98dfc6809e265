"""Per-rule times rolled from Snakemake benchmark files (microdoppler.io.ruletimes)."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest

from microdoppler.errors import InputError
from microdoppler.io import ruletimes

HEADER = "s\th:m:s\tmax_rss\tmax_vms\tmax_uss\tmax_pss\tio_in\tio_out\tmean_load\tcpu_time\n"
REPO = Path(__file__).resolve().parents[1]


def bench(path: Path, s: float, rss: float, cpu: float) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(HEADER + f"{s}\t0:00:{int(s):02d}\t{rss}\t1\t1\t1\t0\t0\t50\t{cpu}\n")


def test_rolls_jobs_into_one_row_per_rule(tmp_path):
    root = tmp_path / "benchmarks"
    bench(root / "split_flights.tsv", 10.0, 200.0, 9.0)
    bench(root / "train_classifier" / "real.tsv", 40.0, 450.0, 38.0)
    bench(root / "train_classifier" / "sub_cpi.tsv", 44.0, 470.0, 41.0)
    bench(root / "synthesize_flights" / "sub_cpi" / "batch0.tsv", 5.0, 300.0, 4.0)
    table = ruletimes.rule_times(ruletimes.read_benchmarks(root)).set_index("rule")
    assert list(table.index) == ["train_classifier", "split_flights", "synthesize_flights", "all"]
    train = table.loc["train_classifier"]
    assert (train.jobs, train.total_s, train.max_s, train.cpu_s, train.peak_rss_mib) == (2, 84.0, 44.0, 79.0, 470.0)
    assert table.loc["synthesize_flights", "jobs"] == 1  # a batch's file is its rule's
    everything = table.loc["all"]
    assert (everything.jobs, everything.total_s, everything.max_s, everything.peak_rss_mib) == (4, 99.0, 44.0, 470.0)


def test_only_the_listed_files_that_exist(tmp_path):
    root = tmp_path / "benchmarks"
    bench(root / "a.tsv", 1.0, 10.0, 1.0)
    bench(root / "b" / "x.tsv", 2.0, 10.0, 2.0)  # a file of an earlier layout, not listed
    jobs = ruletimes.read_benchmarks(root, [root / "a.tsv", root / "c.tsv"])
    assert list(jobs.rule) == ["a"]


def test_a_file_that_is_not_a_benchmark_names_itself(tmp_path):
    root = tmp_path / "benchmarks"
    root.mkdir()
    (root / "broken.tsv").write_text("wall\n3\n")
    with pytest.raises(InputError, match=r"broken\.tsv.*s,cpu_time,max_rss"):
        ruletimes.read_benchmarks(root)


def test_written_table_reads_back_and_compares_with_ratios(tmp_path):
    root = tmp_path / "benchmarks"
    bench(root / "a.tsv", 20.0, 10.0, 18.0)
    bench(root / "b.tsv", 5.0, 10.0, 5.0)
    now = ruletimes.rule_times(ruletimes.read_benchmarks(root))
    ruletimes.write_rule_table(now, tmp_path / "t.csv")
    back = ruletimes.read_rule_times(tmp_path / "t.csv")
    pd.testing.assert_frame_equal(back, now, check_dtype=False)
    ref = now.assign(total_s=now.total_s * 2, cpu_s=now.cpu_s * 4)
    ref = pd.concat([ref, pd.DataFrame([{"rule": "gone", "jobs": 1, "total_s": 3.0, "cpu_s": 3.0}])])
    cmp = ruletimes.compare_rule_times(now, ref).set_index("rule")
    assert cmp.loc["a", "total_ratio"] == 0.5 and cmp.loc["a", "cpu_ratio"] == 0.25
    assert pd.isna(cmp.loc["gone", "total_ratio"])  # a rule of the record only
    assert cmp.index[-1] == "all"
    with pytest.raises(InputError, match="rule_times"):
        (tmp_path / "rule_times.csv").write_text("rule,seconds\na,1\n")
        ruletimes.read_rule_times(tmp_path / "rule_times.csv")


def test_every_rule_writes_a_benchmark_file():
    """So the per-rule table (rule report_rule_times) sees every stage; the table's own
    rule excepted."""
    missing = []
    for smk in sorted((REPO / "workflow" / "rules").glob("*.smk")):
        text = smk.read_text()
        starts = [(m.start(), m.group(1)) for m in re.finditer(r"(?m)^\s*rule (\w+):", text)]
        for (start, name), (end, _) in zip(starts, starts[1:] + [(len(text), "")]):
            if name != "report_rule_times" and "benchmark:" not in text[start:end]:
                missing.append(f"{smk.name}: {name}")
    assert not missing, missing
