"""``simcalib bench-vision [...]``: visual pose accuracy and throughput
(:mod:`simcalib.studies.bench.vision`, imported when the command runs)."""

from simcalib.cli import register_command

register_command("bench-vision", "simcalib.studies.bench.vision:main",
                 "visual pose accuracy and throughput benchmark", "bench-vision [...]")
