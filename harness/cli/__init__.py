"""The ``mjharness`` command line: :mod:`.commands` (one function per subcommand over the harness's pure
functions) and :mod:`.entry` (the console script: MuJoCo without GL, no interpreter teardown)."""
