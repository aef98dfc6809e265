"""Rule plot_motor_speed_figures: paper Fig. 2 and a Fig. 8-style sampling comparison."""

import pandas as pd

from microdoppler import figures
from microdoppler.io.inventory import read_ingested_log
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    figures.fig2(snakemake.output.fig2, ulog_path=snakemake.input.ulog)
    status = pd.read_csv(snakemake.input.status)
    ingested = status[status.status == "ingested"]
    if len(ingested):
        log = read_ingested_log(snakemake.input.logs, ingested.flight_id.iloc[0])
    else:
        from microdoppler.io.motorlog import read_ulog

        log = read_ulog(snakemake.input.ulog)
    figures.fig8(snakemake.output.fig8, motor_log=log)
