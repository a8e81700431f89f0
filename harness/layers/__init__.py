"""The layers of checking, each turning runs into named figures (design.md, "The four layers"):
:mod:`.instant` (layer 2, at sampled states), :mod:`.trajectory` (layer 3, runs against the
reference), :mod:`.orders` (layer 4, convergence orders) and :mod:`.reference` (the reference's
own quality). Layer 1, the derivation, is checked by the tests and the seed audit."""
