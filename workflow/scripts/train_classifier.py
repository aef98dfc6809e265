"""Rule train_classifier: train one training set's classifiers, one per seed in turn
(the tiles read once, one process), and save each kept epoch and its history."""

import logging

from microdoppler.classifier import TrainConfig, load_trainset, save_model, train
from microdoppler.io.outputs import atomic_file
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    trainset = snakemake.wildcards.trainset
    cfg = TrainConfig.from_config(snakemake.params.classifier)
    tiles_dir = snakemake.input.real.rsplit("/", 1)[0]
    train_set, val_set, _ = load_trainset(trainset, tiles_dir)
    logger = logging.getLogger("train_classifier")
    seeds = snakemake.params.seeds
    for i, (seed, model, history) in enumerate(zip(seeds, snakemake.output.models, snakemake.output.histories)):
        logger.info("%s: seed %d (%d of %d)", trainset, seed, i + 1, len(seeds))
        result = train(train_set, val_set, cfg, seed=seed, threads=snakemake.threads, logger=logger)
        save_model(model, result, cfg, seed=seed, trainset=trainset)
        with atomic_file(history) as tmp:
            result.history.to_csv(tmp, index=False, float_format="%.6g")
