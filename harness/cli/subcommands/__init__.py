"""The subcommands of ``mjharness``, a module each: its arguments, ``cmd_NAME(args) -> int`` translating them into
the harness's functions and the outcome into text and an exit code, and its ``COMMAND`` for the table in
:mod:`harness.cli.commands`."""

__all__: list[str] = []
