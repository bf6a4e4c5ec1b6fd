"""``simcalib experiment NAME [key=value ...]``: the paper's experiments and the studies of
:mod:`simcalib.studies.experiments` (imported when the command runs)."""

from simcalib.cli import register_command

register_command("experiment", "simcalib.studies.experiments:main",
                 "reproduce the paper's experiments (and the streams, recordings and "
                 "real-data studies)", "experiment NAME [key=value ...]")
