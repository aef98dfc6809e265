if MEASURED_SOURCE == "emulator":

    rule emulate_measurements:
        output:
            measured=directory(MEASURED_DIR),
            key="results/emulator/key.json",
        log:
            "results/logs/emulate_measurements.log",
        benchmark:
            "results/benchmarks/emulate_measurements.tsv"
        conda:
            "../envs/microdoppler.yaml"
        threads: 2
        resources:
            mem_mb=4000,
        params:
            profile=config["emulator"]["profile"],
            seed=config["emulator"]["seed"],
            code=script_code("emulate_measurements.py"),
        script:
            "../scripts/emulate_measurements.py"


rule ingest_motor_logs:
    input:
        measured=MEASURED_DIR,
    output:
        logs=directory("results/motors/logs.zarr"),
        status="results/motors/ingest.csv",
    log:
        "results/logs/ingest_motor_logs.log",
    benchmark:
        "results/benchmarks/ingest_motor_logs.tsv"
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=1000,
    params:
        table=motor_logs_table(),
        estimate=config["measurements"]["estimate_missing_motor_logs"],
        code=script_code("ingest_motor_logs.py"),
    script:
        "../scripts/ingest_motor_logs.py"
