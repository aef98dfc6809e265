"""Rule report_fidelity: Table VI (twin vs measured flight, held-out CPIs) and its
figure, from every variant's scores (rule score_twins)."""

from microdoppler.datasets.fidelity import FidelityConfig, read_scores, write_fidelity_report
from microdoppler.datasets.imaging import spectrogram_for_flights
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    p = snakemake.params
    table = write_fidelity_report(
        snakemake.input.measured,
        snakemake.input.logs,
        dict(zip(p.variants, snakemake.input.injected)),
        snakemake.output.table,
        snakemake.output.figure,
        snakemake.output.flights,
        spec_cfg=spectrogram_for_flights(p.spectrogram, snakemake.input.measured),
        cfg=FidelityConfig.from_config(p.fidelity, p.calibration, p.search_hz),
        n_boot=p.fidelity["n_boot"],
        seed=p.fidelity["seed"],
        left_out_csv=snakemake.output.left_out,
        scores={v: read_scores(path) for v, path in zip(p.variants, snakemake.input.scores)},
    )
    print(table.to_string())
