"""Rule diagnose_flights: diagnose one part of the measured drone flights (of the
`diagnosis.sets` split sets; every `diagnosis.flight_batches`-th from the part's
index on); write its report JSON, its one-row-per-flight table and one figure per
flight (rule report_diagnosis gathers the parts)."""

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
        part=(int(snakemake.wildcards.part), snakemake.params.parts),
    )
