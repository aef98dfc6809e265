"""Rule aggregate_extensions: the diagnosed flights' report -> extended.yaml
(extensions/2: each flight's own causes and parameters, and their per-model
population; `mode` says which the `extended` twins use)."""

from microdoppler.diagnosis.pipeline import write_twin_extensions
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    ext = write_twin_extensions(
        snakemake.input.report,
        snakemake.input.split,
        snakemake.output.extensions,
        settings=snakemake.params.diagnosis,
        mode=snakemake.params.mode,
    )
    print(f"mode {ext.mode}: {ext.meta}")
    for model, pop in ext.population.items():
        inc = {c: round(v["incidence"], 2) for c, v in pop["causes"].items()}
        print(f"{model}: {pop['n_flights']} diagnosed flights, incidence {inc}")
