"""Rule plot_twins: measured vs twin spectrograms per drone model (paper Fig. 9/10)."""

from microdoppler.datasets.figures import plot_twins
from microdoppler.datasets.imaging import spectrogram_for_flights
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    injected = dict(zip(snakemake.params.variants, snakemake.input.injected))
    spec_cfg = spectrogram_for_flights(snakemake.params.spectrogram, snakemake.input.measured)
    for model, png in zip(snakemake.params.models, snakemake.output.figures):
        fid = plot_twins(
            snakemake.input.measured,
            injected,
            model,
            png,
            spec_cfg=spec_cfg,
            max_timesteps=snakemake.params.timesteps,
        )
        print(f"{model}: flight {fid} -> {png}")
