"""The ``mjharness`` command line: :mod:`.commands` (the command table, the parser, errors to exit codes),
:mod:`.subcommands` (a module per subcommand over the harness's pure functions), :mod:`.options` (the options
several commands take, each declared once), :mod:`.common` (what several commands share) and :mod:`.entry` (the
console script: MuJoCo without GL, no interpreter teardown)."""

__all__: list[str] = []
