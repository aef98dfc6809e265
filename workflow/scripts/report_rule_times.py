"""Rule report_rule_times: the run's benchmark files rolled into one table, a row per rule."""

from microdoppler.io.ruletimes import read_benchmarks, rule_times, write_rule_table
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    table = rule_times(read_benchmarks(snakemake.params.root, snakemake.params.benchmarks))
    write_rule_table(table, snakemake.output.table)
    print(table.to_string(index=False))
