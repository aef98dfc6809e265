"""Rule measure_flights: the Table VI features of every measured flight a twin is
scored against, measured once for every variant's score_twins."""

from microdoppler.datasets.fidelity import FidelityConfig, measure_flights
from microdoppler.datasets.imaging import spectrogram_for_flights
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    p = snakemake.params
    measure_flights(
        snakemake.input.measured,
        snakemake.input.logs,
        snakemake.output.features,
        spec_cfg=spectrogram_for_flights(p.spectrogram, snakemake.input.measured),
        cfg=FidelityConfig.from_config(p.fidelity, p.calibration, p.search_hz),
    )
