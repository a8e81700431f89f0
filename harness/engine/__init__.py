"""The MuJoCo side: finding and compiling models, putting analytic states into them, recording runs,
and the readings computed from recorded fields. Differences between MuJoCo versions live in
:mod:`.compat` alone."""

__all__: list[str] = []
