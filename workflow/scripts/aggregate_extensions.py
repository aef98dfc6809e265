"""Rule aggregate_extensions: the training flights' diagnosis -> extended.yaml (the
model extensions, with median fitted parameters, of the `extended` variant)."""

from microdoppler.diagnosis.pipeline import aggregate_report
from microdoppler.runlog import log_to

with log_to(snakemake.log[0]):
    ext = aggregate_report(
        snakemake.input.report,
        snakemake.input.split,
        snakemake.output.extensions,
        settings=snakemake.params.diagnosis,
    )
    print(ext.to_dict())
