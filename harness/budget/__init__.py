"""The error budget of every gated figure (:mod:`harness.core.budget` says what a budget is): the model
variants it runs (:mod:`.variants`) and the extrapolations of trajectories (:mod:`.trajectory`) and of
instantaneous quantities (:mod:`.instant`) toward the ideal limits."""
