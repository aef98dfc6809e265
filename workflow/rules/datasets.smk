# Datasets: split, motor speeds per variant, calibrated twins, background
# injection, tiles, Table III/IV and the measured-vs-twin figures.
# Input functions and constants (DATASETS, MOTOR_LOGS, SPLIT, ...) are in common.smk.


rule split_flights:
    input:
        measured=MEASURED_DIR,
    output:
        split=SPLIT,
        table="results/reports/table_iii.csv",
    log:
        "results/logs/split_flights.log",
    benchmark:
        "results/benchmarks/split_flights.tsv"
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=2000,
    params:
        split=config["datasets"]["split"],
        spectrogram=config["spectrogram"],
        search_hz=config["datasets"]["snr_search_hz"],
        code=script_code("split_flights.py"),
    script:
        "../scripts/split_flights.py"


rule resample_motor_speeds:
    input:
        unpack(speeds_inputs),
    output:
        speeds=directory("results/speeds/{variant}.zarr"),
    log:
        "results/logs/resample_motor_speeds/{variant}.log",
    benchmark:
        "results/benchmarks/resample_motor_speeds/{variant}.tsv"
    priority: extended_first
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=2000,
    params:
        settings=variant_settings,
        n_fft=config["sampling"]["n_fft"],
        seed=config["sampling"]["seed"],
        code=script_code("resample_motor_speeds.py"),
    script:
        "../scripts/resample_motor_speeds.py"


rule synthesize_flights:
    input:
        unpack(twins_inputs),
    output:
        twins=directory(SYNTHETIC_BATCH),
        table=TABLE_IV_BATCH,
    log:
        f"results/logs/synthesize_flights/{VARIANT_BATCH}.log",
    benchmark:
        f"results/benchmarks/synthesize_flights/{VARIANT_BATCH}.tsv"
    priority: extended_first
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=3000,
    params:
        settings=variant_settings,
        calibration=config["datasets"]["calibration"],
        search_hz=config["datasets"]["snr_search_hz"],
        spectrogram=config["spectrogram"],
        seed=config["sampling"]["seed"],
        flight_batches=FLIGHT_BATCHES,
        code=script_code("synthesize_flights.py"),
    script:
        "../scripts/synthesize_flights.py"


rule inject_background:
    input:
        measured=MEASURED_DIR,
        twins=SYNTHETIC_BATCH,
    output:
        injected=directory(INJECTED_BATCH),
    log:
        f"results/logs/inject_background/{VARIANT_BATCH}.log",
    benchmark:
        f"results/benchmarks/inject_background/{VARIANT_BATCH}.tsv"
    priority: extended_first
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=2000,
    params:
        code=script_code("inject_background.py"),
    script:
        "../scripts/inject_background.py"


if FLIGHT_BATCHES > 1:

    rule merge_flight_batches:
        input:
            speeds="results/speeds/{variant}.zarr",
            injected=expand(INJECTED_BATCH, variant="{variant}", batch=BATCHES),
            tables=expand(TABLE_IV_BATCH, variant="{variant}", batch=BATCHES),
        output:
            injected=directory("results/injected/{variant}.zarr"),
            table="results/reports/table_iv_{variant}.csv",
        log:
            "results/logs/merge_flight_batches/{variant}.log",
        benchmark:
            "results/benchmarks/merge_flight_batches/{variant}.tsv"
        conda:
            "../envs/microdoppler.yaml"
        threads: 1
        resources:
            mem_mb=1000,
        params:
            code=script_code("merge_flight_batches.py"),
        script:
            "../scripts/merge_flight_batches.py"


rule tile_spectrograms:
    input:
        unpack(tile_inputs),
    output:
        tiles=directory("results/tiles/{dataset}.zarr"),
    log:
        "results/logs/tile_spectrograms/{dataset}.log",
    benchmark:
        "results/benchmarks/tile_spectrograms/{dataset}.tsv"
    priority: extended_first
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=3000,
    params:
        spectrogram=config["spectrogram"],
        search_hz=config["datasets"]["snr_search_hz"],
        code=script_code("tile_spectrograms.py"),
    script:
        "../scripts/tile_spectrograms.py"


rule report_table_iv:
    input:
        tables=expand("results/reports/table_iv_{variant}.csv", variant=VARIANTS),
    output:
        table="results/reports/table_iv.csv",
    log:
        "results/logs/report_table_iv.log",
    benchmark:
        "results/benchmarks/report_table_iv.tsv"
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=500,
    params:
        code=script_code("report_table_iv.py"),
    script:
        "../scripts/report_table_iv.py"


rule plot_twins:
    input:
        measured=MEASURED_DIR,
        injected=expand("results/injected/{variant}.zarr", variant=VARIANTS),
    output:
        figures=[
            report(png, caption="../report/twins.rst", category="Twins")
            for png in expand("results/figures/twins_{model}.png", model=TWIN_MODELS)
        ],
    log:
        "results/logs/plot_twins.log",
    benchmark:
        "results/benchmarks/plot_twins.tsv"
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=2000,
    params:
        variants=VARIANTS,
        models=TWIN_MODELS,
        spectrogram=config["spectrogram"],
        timesteps=config["datasets"]["figure_timesteps"],
        code=script_code("plot_twins.py"),
    script:
        "../scripts/plot_twins.py"
