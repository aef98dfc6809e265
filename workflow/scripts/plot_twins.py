"""Rule plot_twins: measured vs twin spectrograms per drone model (paper Fig. 9/10)."""

from microdoppler.datasets.figures import plot_twins
from microdoppler.io.runlog import log_to
from microdoppler.spectra.spectrogram import SpectrogramConfig

with log_to(snakemake.log[0]):
    injected = dict(zip(snakemake.params.variants, snakemake.input.injected))
    for model, png in zip(snakemake.params.models, snakemake.output.figures):
        fid = plot_twins(
            snakemake.input.measured, injected, model, png,
            spec_cfg=SpectrogramConfig(**snakemake.params.spectrogram),
            max_timesteps=snakemake.params.timesteps,
        )
        print(f"{model}: flight {fid} -> {png}")
