# Direct twin fidelity: every variant's injected twins against their
# measured flights, feature by feature, on the CPIs the calibration did not see
# (Table VI, src/microdoppler/datasets/fidelity.py). The measured flights are
# measured once (measure_flights); each variant is scored as soon as its twins are
# injected (score_twins, one job per variant); report_fidelity only gathers.


rule measure_flights:
    input:
        measured=MEASURED_DIR,
        logs=MOTOR_LOGS,
    output:
        features=directory("results/fidelity/measured.zarr"),
    log:
        "results/logs/measure_flights.log",
    benchmark:
        "results/benchmarks/measure_flights.tsv"
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=3000,
    params:
        spectrogram=config["spectrogram"],
        search_hz=config["datasets"]["snr_search_hz"],
        calibration=config["datasets"]["calibration"],
        fidelity=config["fidelity"],
        code=script_code("measure_flights.py"),
    script:
        "../scripts/measure_flights.py"


rule score_twins:
    input:
        measured=MEASURED_DIR,
        logs=MOTOR_LOGS,
        features="results/fidelity/measured.zarr",
        injected="results/injected/{variant}.zarr",
    output:
        scores="results/fidelity/{variant}.csv",
    log:
        "results/logs/score_twins/{variant}.log",
    benchmark:
        "results/benchmarks/score_twins/{variant}.tsv"
    priority: extended_first
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=3000,
    params:
        spectrogram=config["spectrogram"],
        search_hz=config["datasets"]["snr_search_hz"],
        calibration=config["datasets"]["calibration"],
        fidelity=config["fidelity"],
        code=script_code("score_twins.py"),
    script:
        "../scripts/score_twins.py"


rule report_fidelity:
    input:
        measured=MEASURED_DIR,
        logs=MOTOR_LOGS,
        injected=expand("results/injected/{variant}.zarr", variant=VARIANTS),
        scores=expand("results/fidelity/{variant}.csv", variant=VARIANTS),
    output:
        table=report(
            "results/reports/table_vi.csv",
            caption="../report/table_vi.rst",
            category="Twin fidelity",
        ),
        figure=report(
            "results/reports/fig_fidelity.png",
            caption="../report/table_vi.rst",
            category="Twin fidelity",
        ),
        flights="results/reports/fidelity_flights.csv",
        left_out="results/reports/fidelity_left_out.csv",
    log:
        "results/logs/report_fidelity.log",
    benchmark:
        "results/benchmarks/report_fidelity.tsv"
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=2000,
    params:
        variants=VARIANTS,
        spectrogram=config["spectrogram"],
        search_hz=config["datasets"]["snr_search_hz"],
        calibration=config["datasets"]["calibration"],
        fidelity=config["fidelity"],
        code=script_code("report_fidelity.py"),
    script:
        "../scripts/report_fidelity.py"
