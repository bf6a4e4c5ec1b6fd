from simcalib.cli import run

run()
