"""Rule emulate_measurements: the measurement emulator's world (embedded default)."""

from microdoppler.emulator import emulate_world
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    emulate_world(
        snakemake.params.profile,
        int(snakemake.params.seed),
        snakemake.output.measured,
        key_path=snakemake.output.key,
    )
