"""Second opinions: independent peers that judge what MuJoCo computes, never the reference.

- :mod:`harness.opinions.pinocchio`: Pinocchio built from MuJoCo's compiled model, and the conventions
  between the two (quaternion order, a free joint's velocity frame);
- :mod:`harness.opinions.threeway`: MuJoCo, the tree reference and Pinocchio at sampled states (M, bias
  forces, forward and inverse dynamics), naming the one that is off where two agree;
- :mod:`harness.opinions.urdf`: a robot's URDF (through Pinocchio) against MuJoCo's model of its MJCF, body by
  body and joint by joint;
- :mod:`harness.opinions.parser`: Pinocchio's own MJCF parser against MuJoCo's compiler, advisory only.

Pinocchio is the optional extra ``pip install 'mjharness[pin]'``; without it each opinion says in one line
what it skipped.
"""

__all__: list[str] = []
