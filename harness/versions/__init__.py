"""What changed between MuJoCo versions: ``mjharness versions``.

One isolated environment per MuJoCo release (:mod:`~harness.versions.envs`, built with uv and kept in the
user's cache), the same ``check --json`` run in each (:mod:`~harness.versions.runs`), twice more with the
initial state moved at round-off level to measure each figure's noise, and the runs compared release by
release (:mod:`~harness.versions.changes`): verdict flips (known defects included), figures that moved
beyond their noise, figures that appeared or vanished, each with the release where it happened.
:mod:`~harness.versions.bisect` finds the first release of a change installing only the releases it
needs; :mod:`~harness.versions.releases` asks the package index which releases exist;
:mod:`~harness.versions.changes_report` writes the text, HTML and JSON.
"""

__all__: list[str] = []
