"""Rule evaluate_classifier: predictions of one trained classifier on the measured test tiles."""

import torch

from microdoppler.classifier import load_model, predict, predictions_table, read_tiles
from microdoppler.io.outputs import atomic_file
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    torch.set_num_threads(snakemake.threads)
    model, cfg = load_model(snakemake.input.model)
    real = read_tiles(snakemake.input.real)
    test = real.subset(real.labels["set"] == "test")
    table = predictions_table(test, predict(model, test.images, cfg.normalisation))
    with atomic_file(snakemake.output.predictions) as tmp:
        table.to_csv(tmp, index=False, float_format="%.6g")
    print(f"{len(table)} test tiles, accuracy {(table.target == table.predicted).mean():.3f}")
