"""Rule evaluate_classifier: predictions of one training set's classifiers (one per
seed) on the measured test tiles."""

import torch

from microdoppler.classifier import load_model, predict, predictions_table, read_tiles
from microdoppler.io.outputs import atomic_file
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    torch.set_num_threads(snakemake.threads)
    real = read_tiles(snakemake.input.real)
    test = real.subset(real.labels["set"] == "test")
    for seed, path, out in zip(snakemake.params.seeds, snakemake.input.models, snakemake.output.predictions):
        model, cfg = load_model(path)
        table = predictions_table(test, predict(model, test.images, cfg.normalisation))
        with atomic_file(out) as tmp:
            table.to_csv(tmp, index=False, float_format="%.6g")
        accuracy = (table.target == table.predicted).mean()
        print(f"{snakemake.wildcards.trainset} seed {seed}: {len(table)} test tiles, accuracy {accuracy:.3f}")
