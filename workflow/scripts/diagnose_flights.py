"""Rule diagnose_flights: diagnose the measured drone flights (of the `diagnosis.sets` split sets) that have a
motor log; write the report JSON, its one-row-per-flight table (report.csv, beside it) and one figure per
flight, diagnosing `threads` flights side by side."""

from microdoppler.diagnosis.pipeline import diagnose_split
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    diagnose_split(
        snakemake.input.measured,
        snakemake.input.logs,
        snakemake.input.split,
        snakemake.output.report,
        snakemake.output.figures,
        settings=snakemake.params.diagnosis,
        processes=snakemake.threads,
    )
