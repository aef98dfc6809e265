"""Rule train_classifier: train one classifier ({trainset}, {seed}) and save the kept epoch."""

import logging

from microdoppler.classifier import TrainConfig, load_trainset, save_model, train
from microdoppler.io.outputs import atomic_file
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    trainset, seed = snakemake.wildcards.trainset, int(snakemake.wildcards.seed)
    cfg = TrainConfig.from_config(snakemake.params.classifier)
    tiles_dir = snakemake.input.real.rsplit("/", 1)[0]
    train_set, val_set, _ = load_trainset(trainset, tiles_dir)
    result = train(
        train_set, val_set, cfg, seed=seed, threads=snakemake.threads, logger=logging.getLogger("train_classifier")
    )
    save_model(snakemake.output.model, result, cfg, seed=seed, trainset=trainset)
    with atomic_file(snakemake.output.history) as tmp:
        result.history.to_csv(tmp, index=False, float_format="%.6g")
