"""The command-line sub-commands: one module per command, each with ``main(args) -> int``
(registered in :data:`simcalib.cli.COMMANDS`). Errors are raised as typed
:mod:`simcalib.errors` exceptions; :func:`simcalib.cli.main` turns them into one-line
messages and exit codes."""
