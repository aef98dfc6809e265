rule plot_motor_speed_figures:
    input:
        logs="results/motors/logs.zarr",
        status="results/motors/ingest.csv",
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
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=2000,
    params:
        ulog=config["figures"]["ulog"],
        code=code_version("figures.py", "synthesis.py", "sampling.py"),
    script:
        "../scripts/plot_motor_speed_figures.py"
