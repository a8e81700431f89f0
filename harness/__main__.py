"""``python -m harness``: the ``mjharness`` command."""

from harness.cli.entry import entry

entry()
