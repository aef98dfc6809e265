"""Rule inject_background: each twin added to its flight's background/iq."""

from microdoppler.datasets.injection import build_injected
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    done = build_injected(snakemake.input.measured, snakemake.input.twins, snakemake.output.injected)
    print(f"{len(done)} twins injected")
