"""Rule split_flights: flight-disjoint 60:30:10 split by class and Table III."""

from microdoppler.datasets.imaging import spectrogram_for_flights
from microdoppler.datasets.tables import write_csv
from microdoppler.datasets.workflow import split_and_table_iii
from microdoppler.io.runlog import log_to

with log_to(snakemake.log[0]):
    split, table = split_and_table_iii(
        snakemake.input.measured,
        spec_cfg=spectrogram_for_flights(snakemake.params.spectrogram, snakemake.input.measured),
        search_hz=snakemake.params.search_hz,
        **snakemake.params.split,
    )
    # snr_line: only where some flight's SNR is read on its rotor lines (body in the notch)
    cols = ["flight_id", "set", "target", "drone_model", "radar_id"] + (["snr_line"] if "snr_line" in split else [])
    write_csv(split[cols], snakemake.output.split)
    write_csv(table, snakemake.output.table)
    print(table.to_string())
