"""``simcalib bench [...]``: solver timings (:mod:`simcalib.studies.bench.solvers`, imported
when the command runs)."""

from simcalib.cli import register_command

register_command("bench", "simcalib.studies.bench.solvers:main",
                 "solver benchmark (Table-1-like timings)", "bench [...]")
