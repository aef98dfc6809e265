# Diagnosis: what the paper's simulation gets wrong about the measured
# drone flights (every split set by default), and the `extended` variant's model extensions.
# Needs from common.smk: config (validated), MEASURED_DIR, script_code.
# Uses the outputs of ingest_motor_logs (results/motors/logs.zarr) and split_flights
# (results/splits/flights.csv).


rule diagnose_flights:
    input:
        measured=MEASURED_DIR,
        logs="results/motors/logs.zarr",
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
        "results/logs/diagnose_flights.log",
    benchmark:
        "results/benchmarks/diagnose_flights.tsv"
    conda:
        "../envs/microdoppler.yaml"
    # flights diagnosed side by side (forked workers); the report is the same for any number
    threads: 2
    resources:
        mem_mb=4000,
    params:
        diagnosis=config["diagnosis"],
        code=script_code("diagnose_flights.py"),
    script:
        "../scripts/diagnose_flights.py"


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
