# Classifier stage: train over seeds per training set, evaluate on the
# measured test tiles, report Table V, the mean confusion matrices (Fig. 6) and
# the Fig. 12 box plot.


rule train_classifier:
    input:
        unpack(classifier_tiles),
    output:
        # one job per training set trains its seeds in turn (the tiles read once)
        models=expand("results/models/{{trainset}}/seed{seed}.pt", seed=SEEDS),
        histories=expand(
            "results/models/{{trainset}}/seed{seed}_history.csv", seed=SEEDS
        ),
    log:
        "results/logs/train_classifier/{trainset}.log",
    benchmark:
        "results/benchmarks/train_classifier/{trainset}.tsv"
    wildcard_constraints:
        trainset="|".join(TRAINSETS),
    priority: extended_first
    conda:
        "../envs/microdoppler.yaml"
    threads: CLASSIFIER.get("threads", 1)
    resources:
        mem_mb=2000,
        # one GPU per job on a cluster for the paper's AlexNet (profiles/slurm)
        gpu=CLASSIFIER_GPUS,
    params:
        classifier=CLASSIFIER,
        seeds=SEEDS,
        code=script_code("train_classifier.py"),
    script:
        "../scripts/train_classifier.py"


rule evaluate_classifier:
    input:
        models=expand("results/models/{{trainset}}/seed{seed}.pt", seed=SEEDS),
        real="results/tiles/real.zarr",
    output:
        predictions=expand("results/eval/{{trainset}}/seed{seed}.csv", seed=SEEDS),
    log:
        "results/logs/evaluate_classifier/{trainset}.log",
    benchmark:
        "results/benchmarks/evaluate_classifier/{trainset}.tsv"
    wildcard_constraints:
        trainset="|".join(TRAINSETS),
    priority: extended_first
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=1000,
    params:
        seeds=SEEDS,
        code=script_code("evaluate_classifier.py"),
    script:
        "../scripts/evaluate_classifier.py"


rule report_metrics:
    input:
        predictions=classifier_predictions(),
    output:
        metrics=report(
            "results/reports/metrics.csv",
            caption="../report/metrics.rst",
            category="Classifier",
        ),
        table_v=report(
            "results/reports/table_v.csv",
            caption="../report/table_v.rst",
            category="Classifier",
        ),
        confusion_csv=expand(
            "results/reports/confusion_{trainset}.csv", trainset=TRAINSETS
        ),
        confusion_png=report(
            expand("results/reports/confusion_{trainset}.png", trainset=TRAINSETS),
            caption="../report/fig6.rst",
            category="Classifier",
            subcategory="Fig. 6 confusion matrices",
        ),
        fig12=report(
            "results/reports/fig12_boxplot.png",
            caption="../report/fig12.rst",
            category="Classifier",
        ),
    log:
        "results/logs/report_metrics.log",
    benchmark:
        "results/benchmarks/report_metrics.tsv"
    conda:
        "../envs/microdoppler.yaml"
    threads: 1
    resources:
        mem_mb=1000,
    params:
        trainsets=TRAINSETS,
        seeds=SEEDS,
        code=script_code("report_metrics.py"),
    script:
        "../scripts/report_metrics.py"
