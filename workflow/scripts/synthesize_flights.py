"""Rule synthesize_flights: calibrated synthetic twins of one variant (one flight batch
of it when datasets.flight_batches > 1) and their Table IV rows."""

from microdoppler.datasets.calibration import CalibrationConfig, build_twins
from microdoppler.datasets.imaging import spectrogram_for_flights
from microdoppler.datasets.workflow import load_extensions
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    batch = snakemake.wildcards.get("batch")
    table = build_twins(
        snakemake.input.measured,
        snakemake.input.speeds,
        snakemake.input.logs,
        snakemake.output.twins,
        snakemake.output.table,
        variant=snakemake.wildcards.variant,
        spec_cfg=spectrogram_for_flights(snakemake.params.spectrogram, snakemake.input.measured),
        cfg=CalibrationConfig.from_config(snakemake.params.calibration, snakemake.params.search_hz),
        seed=snakemake.params.seed,
        extensions=load_extensions(snakemake.input.get("extensions")),
        batch=None if batch is None else (int(batch), snakemake.params.flight_batches),
    )
    print(table.status.value_counts().to_string())
