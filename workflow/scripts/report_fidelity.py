"""Rule report_fidelity: Table VI (twin vs measured flight, held-out CPIs) and its figure."""

from microdoppler.datasets.fidelity import FidelityConfig, write_fidelity_report
from microdoppler.datasets.imaging import spectrogram_for_flights
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    settings = dict(snakemake.params.fidelity)
    calibration = snakemake.params.calibration
    cfg = FidelityConfig(
        visible_db=calibration.get("visible_db", 10.0),
        n_harmonics=calibration.get("n_harmonics", 6),
        search_hz=snakemake.params.search_hz,
        clutter_span_hz=settings["clutter_span_hz"],
        max_lag_cpis=settings["max_lag_cpis"],
    )
    table = write_fidelity_report(
        snakemake.input.measured,
        snakemake.input.logs,
        dict(zip(snakemake.params.variants, snakemake.input.injected)),
        snakemake.output.table,
        snakemake.output.figure,
        snakemake.output.flights,
        spec_cfg=spectrogram_for_flights(snakemake.params.spectrogram, snakemake.input.measured),
        cfg=cfg,
        n_boot=settings["n_boot"],
        seed=settings["seed"],
        left_out_csv=snakemake.output.left_out,
    )
    print(table.to_string())
