"""Seeded whole-message loss processes."""

import random

from latency.profile import Loss


class LossProcess:
    """Decides, message by message, whether the link loses it."""

    def __init__(self, spec: Loss, salt: int) -> None:
        self._spec = spec
        self._rng = random.Random(spec.seed * 1_000_003 + salt)
        self._bad = False

    def lost(self) -> bool:
        spec = self._spec
        if spec.model == "none":
            return False
        if spec.model == "bernoulli":
            return self._rng.random() < spec.probability
        # Gilbert-Elliott: a two-state Markov chain stepped once per message.
        if self._bad:
            self._bad = self._rng.random() >= spec.p_bad_to_good
        else:
            self._bad = self._rng.random() < spec.p_good_to_bad
        return self._rng.random() < (spec.loss_in_bad if self._bad else spec.loss_in_good)
