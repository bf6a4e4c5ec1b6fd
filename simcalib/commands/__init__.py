"""The command-line sub-commands: one module per command. Each registers itself in
:data:`simcalib.cli.COMMANDS` (``@command(name, summary=..., usage=...)`` on its
``main(args) -> int``, or ``register_command(name, "module:function", ...)`` for code
that lives elsewhere); the registry imports every module of this folder on its first
lookup, so a new command is one new file. Errors are raised as typed
:mod:`simcalib.errors` exceptions; :func:`simcalib.cli.main` turns them into one-line
messages and exit codes. Keep these modules light: heavy imports inside ``main``."""
