"""``python -m harness.cli``: the ``mjharness`` command."""

from harness.cli.entry import entry

__all__: list[str] = []

entry()
