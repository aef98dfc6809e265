"""Rule resample_motor_speeds: logged motor speeds at pulse rate for one variant."""

from microdoppler.datasets.speeds import build_speeds
from microdoppler.datasets.workflow import load_extensions
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    status = build_speeds(
        snakemake.input.measured,
        snakemake.input.logs,
        snakemake.output.speeds,
        variant=snakemake.wildcards.variant,
        settings=snakemake.params.settings,
        n_fft=snakemake.params.n_fft,
        seed=snakemake.params.seed,
        extensions=load_extensions(snakemake.input.get("extensions")),
    )
    print(status.to_string())
