"""Rule tile_spectrograms: 20-timestep spectrogram images of `real` or a variant's twins."""

from microdoppler.datasets.imaging import spectrogram_for_flights
from microdoppler.datasets.split import read_split
from microdoppler.datasets.tiles import build_tiles, measured_records, twin_records
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    split = read_split(snakemake.input.split)
    spec_cfg = spectrogram_for_flights(snakemake.params.spectrogram, snakemake.input.measured)
    dataset = snakemake.wildcards.dataset
    if dataset == "real":
        records = measured_records(snakemake.input.measured, split)
    else:
        records = twin_records(snakemake.input.measured, snakemake.input.injected, split)
    labels = build_tiles(
        records,
        split,
        snakemake.output.tiles,
        dataset=dataset,
        spec_cfg=spec_cfg,
        search_hz=snakemake.params.search_hz,
    )
    print(labels.groupby(["set", "drone_model"]).size().to_string())
