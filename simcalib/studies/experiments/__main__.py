import sys

from simcalib.cli import main

# same as `python -m simcalib experiment ...` (one-line errors, exit codes of docs/cli.md)
raise SystemExit(main(["experiment", *sys.argv[1:]]))
