"""Rule merge_flight_batches: one variant's injected twins and Table IV rows, gathered
from its flight batches (datasets.flight_batches > 1) into the per-variant products."""

from microdoppler.datasets.batches import merge_stores, merge_tables
from microdoppler.datasets.injection import INJECTED_SCHEMA
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    merge_stores(snakemake.input.injected, snakemake.output.injected, INJECTED_SCHEMA)
    merge_tables(snakemake.input.tables, snakemake.input.speeds, snakemake.output.table)
