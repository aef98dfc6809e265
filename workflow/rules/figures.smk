# Simulator figures: paper Fig. 2 (HERM lines, Fig. 2c from a real PX4 log) and a
# Fig. 8-style per-CPI vs sub-CPI sampling comparison.


rule plot_motor_speed_figures:
    input:
        logs="results/motors/logs.zarr",
        status="results/motors/ingest.csv",
        # the PX4 log for Fig. 2c (config figures.ulog, relative to the working
        # directory): an input, so a missing file fails before the run and an
        # edit reruns the figures
        ulog=config["figures"]["ulog"],
    output:
        fig2=report(
            "results/figures/fig2_herm_lines.png",
            caption="../report/fig2.rst",
            category="Simulator",
        ),
        fig8=report(
            "results/figures/fig8_sampling.png",
            caption="../report/fig8.rst",
            category="Simulator",
        ),
    log:
        "results/logs/plot_motor_speed_figures.log",
    benchmark:
        "results/benchmarks/plot_motor_speed_figures.tsv"
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=2000,
    params:
        code=script_code("plot_motor_speed_figures.py"),
    script:
        "../scripts/plot_motor_speed_figures.py"
