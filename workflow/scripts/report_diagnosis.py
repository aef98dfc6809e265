"""Rule report_diagnosis: the parts' reports, tables and figures gathered into the
diagnosis report of every diagnosed flight (report.json, report.csv, figures/)."""

from microdoppler.diagnosis.pipeline import merge_reports
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    report = merge_reports(
        snakemake.input.reports,
        snakemake.input.split,
        snakemake.output.report,
        snakemake.input.figures,
        snakemake.output.figures,
        settings=snakemake.params.diagnosis,
    )
    print(f"{len(report['flights'])} flights from {len(snakemake.input.reports)} parts")
