"""Rule report_table_iv: the per-variant fits summarised like the paper's Table IV."""

from microdoppler.datasets.tables import aggregate_table_iv, write_csv
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    table = aggregate_table_iv(snakemake.input.tables)
    write_csv(table, snakemake.output.table)
    print(table.to_string())
