"""``mjharness list``: list the cases."""

from __future__ import annotations

import argparse
import textwrap

from harness import cases
from harness.cli.common import EXIT_OK, Command
from harness.cli.options import add_systems
from harness.core.tables import terminal_width, wrap

__all__ = ["COMMAND"]


def _args_list(p: argparse.ArgumentParser) -> None:
    add_systems(p)


def cmd_list(args: argparse.Namespace) -> int:
    """A case a line or a few: its name, then its description and tags wrapped beside it to the terminal's
    width (:func:`~harness.outputs.table.terminal_width`)."""
    unavailable = cases.unavailable()
    rows = [(c.name, f"{c.description} [{','.join(sorted(c.tags))}]") for c in cases.all_cases()]
    rows += [(name, f"not run here: {why} [n/a]") for name, why in unavailable.items()]
    names = max(len(name) for name, _ in rows) + 2
    width = terminal_width()
    for name, text in rows:
        if width - names >= 30:  # the text beside the name, in a column of its own
            lines = textwrap.wrap(text, width - names, break_on_hyphens=False)
            print("\n".join(f"{name if i == 0 else '':<{names}}{line}" for i, line in enumerate(lines)))
        else:  # too narrow for a column: the text below the name
            print("\n".join([name, *wrap(text, width, "    ", "")]))
    return EXIT_OK


COMMAND = Command("list the cases", _args_list, cmd_list)
