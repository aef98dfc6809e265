"""Rule ingest_motor_logs: every drone flight's motor log into results/motors/logs.zarr."""

from microdoppler.io.inventory import ingest_flight_logs
from microdoppler.io.runlog import log_to
from microdoppler.rotors.speed import estimate_rotor_speeds

with log_to(snakemake.log[0]):
    status = ingest_flight_logs(
        snakemake.input.measured,
        snakemake.output.logs,
        snakemake.output.status,
        table_path=snakemake.params.table or None,
        estimator=estimate_rotor_speeds if snakemake.params.estimate else None,
    )
    print(status.status.value_counts().to_string())
