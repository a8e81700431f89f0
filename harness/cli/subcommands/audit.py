"""``mjharness audit``: the seed documents' claims, checked."""

from __future__ import annotations

import argparse
import sys

from harness.cli.common import EXIT_OK, Command
from harness.cli.options import add_json
from harness.outputs.jsondoc import dumps

__all__ = ["COMMAND"]


def _args_audit(p: argparse.ArgumentParser) -> None:
    add_json(p)


def cmd_audit(args: argparse.Namespace) -> int:
    from harness.audit.verdicts import audit  # lazy: sympy, only for this command
    from harness.outputs.audit import format_table, json_rows  # lazy: as above

    rows = audit()
    if args.json:
        sys.stdout.write(dumps(json_rows(rows)))
    else:
        print(format_table(rows))
    return EXIT_OK


COMMAND = Command("the seed documents' claims, checked", _args_audit, cmd_audit,
                  "the seed documents' claims: confirmed, refuted (with the correction) or ambiguous")
