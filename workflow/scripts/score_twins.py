"""Rule score_twins: one variant's injected twins against their measured flights
(Table VI's per-flight distances, on the held-out CPIs)."""

from microdoppler.datasets.fidelity import FidelityConfig, read_measured_features, score_variant, write_scores
from microdoppler.datasets.imaging import spectrogram_for_flights
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    p = snakemake.params
    scores = score_variant(
        snakemake.input.measured,
        snakemake.input.logs,
        snakemake.input.injected,
        snakemake.wildcards.variant,
        spec_cfg=spectrogram_for_flights(p.spectrogram, snakemake.input.measured),
        cfg=FidelityConfig.from_config(p.fidelity, p.calibration, p.search_hz),
        cache=read_measured_features(snakemake.input.features),
    )
    write_scores(scores, snakemake.output.scores)
