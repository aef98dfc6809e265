"""Rule ingest_motor_logs: every drone flight's motor log into results/motors/logs.zarr."""

from microdoppler.io.inventory import ingest_flight_logs
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    status = ingest_flight_logs(
        snakemake.input.measured,
        snakemake.output.logs,
        snakemake.output.status,
        table_path=snakemake.params.table or None,
        estimate_missing=snakemake.params.estimate,
    )
    print(status.status.value_counts().to_string())
