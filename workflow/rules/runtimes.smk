# Per-rule times: every job's benchmark file (results/benchmarks/) rolled into one
# table, a row per rule (jobs, total and max seconds, CPU seconds, peak memory), so a
# slow stage shows without reading logs (src/microdoppler/io/ruletimes.py). It runs
# after every other target of the run; benchmarks/rule_times.py compares it with a
# recorded run.


rule report_rule_times:
    input:
        all_targets(),
    output:
        table=report(
            "results/reports/rule_times.csv",
            caption="../report/rule_times.rst",
            category="Run times",
        ),
    log:
        "results/logs/report_rule_times.log",
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=500,
    params:
        root="results/benchmarks",
        benchmarks=rule_benchmark_files,
        code=script_code("report_rule_times.py"),
    script:
        "../scripts/report_rule_times.py"
