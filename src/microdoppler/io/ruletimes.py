"""Per-rule times of a pipeline run, from Snakemake's ``benchmark:`` files.

Every rule of the workflow writes a benchmark file per job (``results/benchmarks/
<rule>.tsv`` for a rule with one job, ``results/benchmarks/<rule>/<job>.tsv`` for
one with wildcards): the job's wall-clock seconds (``s``), CPU seconds (``cpu_time``)
and peak resident memory (``max_rss``, MiB). :func:`rule_times` rolls them into one
table, a row per rule (jobs, total and max seconds, CPU seconds, peak memory), so a
slow stage is visible without reading logs; the pipeline writes it as
``results/reports/rule_times.csv`` (rule ``report_rule_times``) and the docs' results
page shows it. :func:`compare_rule_times` puts a run's table beside a reference
(``benchmarks/rule_times.py``: ratios per rule, so a regression shows before it
lands).

The seconds are those of the latest run of each job (a job that was not rerun keeps
its earlier file); the total of the table is CPU-busy job time, not the run's wall
clock, which is shorter when jobs ran side by side.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError

#: columns of :func:`rule_times`
COLUMNS = ("rule", "jobs", "total_s", "max_s", "cpu_s", "peak_rss_mib")
#: the columns every Snakemake benchmark file holds that the table reads
BENCHMARK_FIELDS = ("s", "cpu_time", "max_rss")


def read_benchmarks(root, files=None) -> pd.DataFrame:
    """One row per job: rule, job, s, cpu_time, max_rss (MiB), from the benchmark
    files under ``root`` (``<rule>.tsv`` or ``<rule>/<job>.tsv``; a repeated
    benchmark's rows are averaged): all of them, or those of ``files`` (paths under
    ``root``) that exist.

    Raises
    ------
    microdoppler.errors.InputError
        When a benchmark file lacks a field of :data:`BENCHMARK_FIELDS`.
    """
    root = Path(root)
    paths = sorted(root.rglob("*.tsv")) if files is None else sorted(p for p in map(Path, files) if p.exists())
    rows = []
    for path in paths:
        rel = path.relative_to(root)
        rule = rel.parts[0].removesuffix(".tsv")
        job = "/".join(rel.parts[1:]).removesuffix(".tsv") or rule
        df = pd.read_csv(path, sep="\t")
        missing = [c for c in BENCHMARK_FIELDS if c not in df.columns]
        if missing or df.empty:
            raise InputError(
                path,
                ",".join(missing) or "rows",
                "missing in a Snakemake benchmark file",
                "columns s, cpu_time, max_rss",
            )
        values = df[list(BENCHMARK_FIELDS)].apply(pd.to_numeric, errors="coerce").mean()
        rows.append({"rule": rule, "job": job, **values.to_dict()})
    return pd.DataFrame(rows, columns=["rule", "job", *BENCHMARK_FIELDS])


def rule_times(jobs: pd.DataFrame) -> pd.DataFrame:
    """A row per rule (jobs, total_s, max_s, cpu_s, peak_rss_mib), slowest first,
    and a last row ``all`` over every job (its ``max_s`` the slowest job).

    Examples
    --------
    >>> import pandas as pd
    >>> from microdoppler.io.ruletimes import rule_times
    >>> jobs = pd.DataFrame({"rule": ["a", "a", "b"], "job": ["a/1", "a/2", "b"],
    ...                      "s": [2.0, 3.0, 1.0], "cpu_time": [1.5, 2.5, 1.0], "max_rss": [100, 120, 80]})
    >>> rule_times(jobs)[["rule", "jobs", "total_s", "max_s"]].to_dict("records")[0]
    {'rule': 'a', 'jobs': 2, 'total_s': 5.0, 'max_s': 3.0}
    """
    if jobs.empty:
        return pd.DataFrame(columns=COLUMNS)
    g = jobs.groupby("rule", sort=False)
    table = pd.DataFrame(
        {
            "jobs": g.size(),
            "total_s": g["s"].sum(),
            "max_s": g["s"].max(),
            "cpu_s": g["cpu_time"].sum(),
            "peak_rss_mib": g["max_rss"].max(),
        }
    ).reset_index()
    table = table.sort_values(["total_s", "rule"], ascending=[False, True], kind="stable")
    total = {
        "rule": "all",
        "jobs": len(jobs),
        "total_s": jobs["s"].sum(),
        "max_s": jobs["s"].max(),
        "cpu_s": jobs["cpu_time"].sum(),
        "peak_rss_mib": jobs["max_rss"].max(),
    }
    table = pd.concat([table, pd.DataFrame([total])], ignore_index=True)
    table["jobs"] = table["jobs"].astype(int)
    return table[list(COLUMNS)]


def write_rule_table(table: pd.DataFrame, out_csv) -> None:
    """Write a :func:`rule_times` table to ``out_csv`` (atomically, seconds to 0.01 s)."""
    from .outputs import atomic_file

    with atomic_file(out_csv) as tmp:
        table.to_csv(tmp, index=False, float_format="%.2f")


def read_rule_times(path) -> pd.DataFrame:
    """A table written by :func:`write_rule_times` (checked for its columns)."""
    table = pd.read_csv(path)
    missing = [c for c in COLUMNS if c not in table.columns]
    if missing:
        raise InputError(path, ",".join(missing), "missing column", ", ".join(COLUMNS))
    return table


def compare_rule_times(current: pd.DataFrame, reference: pd.DataFrame) -> pd.DataFrame:
    """The two tables side by side, a row per rule of either: ``total_s`` and ``cpu_s``
    of each and their ratios (current / reference; NaN where a rule ran in one only),
    slowest current first, ``all`` last.

    Examples
    --------
    >>> import pandas as pd
    >>> from microdoppler.io.ruletimes import compare_rule_times
    >>> ref = pd.DataFrame({"rule": ["a", "all"], "jobs": [1, 1], "total_s": [10.0, 10.0], "cpu_s": [9.0, 9.0]})
    >>> now = pd.DataFrame({"rule": ["a", "all"], "jobs": [1, 1], "total_s": [5.0, 5.0], "cpu_s": [4.5, 4.5]})
    >>> compare_rule_times(now, ref).loc[0, ["rule", "total_ratio"]].tolist()
    ['a', 0.5]
    """
    cols = ["rule", "jobs", "total_s", "cpu_s"]
    merged = current[cols].merge(reference[cols], on="rule", how="outer", suffixes=("", "_ref"))
    with np.errstate(divide="ignore", invalid="ignore"):
        merged["total_ratio"] = merged["total_s"] / merged["total_s_ref"]
        merged["cpu_ratio"] = merged["cpu_s"] / merged["cpu_s_ref"]
    last = merged["rule"] == "all"
    body = merged[~last].sort_values(["total_s", "total_s_ref"], ascending=False, na_position="last")
    return pd.concat([body, merged[last]], ignore_index=True)
