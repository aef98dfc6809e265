"""Rule report_metrics: metrics.csv, Table V, mean confusion matrices (Fig. 6), Fig. 12."""

from pathlib import Path

import pandas as pd

from microdoppler.classifier.reports import write_reports
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    predictions = {}
    for path in snakemake.input.predictions:
        p = Path(path)  # results/eval/{trainset}/seed{seed}.csv
        predictions[(p.parent.name, int(p.stem.removeprefix("seed")))] = pd.read_csv(p, keep_default_na=False)
    paths = write_reports(
        predictions, Path(snakemake.output.metrics).parent, confusion_trainsets=snakemake.params.trainsets
    )
    print(pd.read_csv(paths["table_v"]).to_string())
