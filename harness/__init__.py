"""MuJoCo side of mjharness: cases, runs, comparison, verdicts, reports and the CLI."""

__version__ = "0.1.0"
