# Diagnosis: what the paper's simulation gets wrong about the measured
# drone flights (every split set by default), and the `extended` variant's model extensions.
# Needs from common.smk: config (validated), MEASURED_DIR, script_code, DIAGNOSIS_PARTS.
# Uses the outputs of ingest_motor_logs (results/motors/logs.zarr) and split_flights
# (results/splits/flights.csv). The diagnosed flights are dealt to
# diagnosis.flight_batches jobs (`{part}`), run side by side, first of all (the
# `extended` variant waits for them: the run's critical path); report_diagnosis
# gathers their reports and figures.


rule diagnose_flights:
    input:
        measured=MEASURED_DIR,
        logs="results/motors/logs.zarr",
        split="results/splits/flights.csv",
    output:
        report=temp("results/diagnosis/parts/{part}.json"),
        table=temp("results/diagnosis/parts/{part}.csv"),
        figures=temp(directory("results/diagnosis/parts/{part}_figures")),
    log:
        "results/logs/diagnose_flights/{part}.log",
    benchmark:
        "results/benchmarks/diagnose_flights/{part}.tsv"
    wildcard_constraints:
        part=r"\d+",
    priority: 20
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=3000,
    params:
        diagnosis=config["diagnosis"],
        parts=len(DIAGNOSIS_PARTS),
        code=script_code("diagnose_flights.py"),
    script:
        "../scripts/diagnose_flights.py"


rule report_diagnosis:
    input:
        reports=expand("results/diagnosis/parts/{part}.json", part=DIAGNOSIS_PARTS),
        tables=expand("results/diagnosis/parts/{part}.csv", part=DIAGNOSIS_PARTS),
        figures=expand("results/diagnosis/parts/{part}_figures", part=DIAGNOSIS_PARTS),
        split="results/splits/flights.csv",
    output:
        report="results/diagnosis/report.json",
        table="results/diagnosis/report.csv",
        figures=report(
            directory("results/diagnosis/figures"),
            patterns=["{flight}.png"],
            caption="../report/diagnosis.rst",
            category="Diagnosis",
        ),
    log:
        "results/logs/report_diagnosis.log",
    benchmark:
        "results/benchmarks/report_diagnosis.tsv"
    priority: 20
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=1000,
    params:
        diagnosis=config["diagnosis"],
        code=script_code("report_diagnosis.py"),
    script:
        "../scripts/report_diagnosis.py"


rule aggregate_extensions:
    input:
        report="results/diagnosis/report.json",
        split="results/splits/flights.csv",
    output:
        extensions="results/diagnosis/extended.yaml",
    log:
        "results/logs/aggregate_extensions.log",
    benchmark:
        "results/benchmarks/aggregate_extensions.tsv"
    priority: 20
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=500,
    params:
        diagnosis=config["diagnosis"],
        mode=config["datasets"]["extended"]["mode"],
        code=script_code("aggregate_extensions.py"),
    script:
        "../scripts/aggregate_extensions.py"
