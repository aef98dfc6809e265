# Direct twin fidelity: every variant's injected twins against their
# measured flights, feature by feature, on the CPIs the calibration did not see
# (Table VI, src/microdoppler/datasets/fidelity.py).
rule report_fidelity:
    input:
        measured=MEASURED_DIR,
        logs=MOTOR_LOGS,
        injected=expand("results/injected/{variant}.zarr", variant=VARIANTS),
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
        mem_mb=3000,
    params:
        variants=VARIANTS,
        spectrogram=config["spectrogram"],
        search_hz=config["datasets"]["snr_search_hz"],
        calibration=config["datasets"]["calibration"],
        fidelity=config["fidelity"],
        code=script_code("report_fidelity.py"),
    script:
        "../scripts/report_fidelity.py"
