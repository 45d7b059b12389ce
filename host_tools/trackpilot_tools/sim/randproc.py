"""Seeded random processes. Every component draws from its own `random.Random`, derived from the
run seed and the component's name, so adding a component never changes another one's numbers."""
import hashlib
import math
import random


def component_rng(seed, name):
    h = hashlib.sha256(("%d/%s" % (seed, name)).encode()).digest()
    return random.Random(int.from_bytes(h[:8], "little"))


class GaussMarkov:
    """First-order Gauss-Markov (Ornstein-Uhlenbeck) process with stationary s.d. `sd` and time
    constant `tau_s`, sampled exactly at arbitrary steps."""

    def __init__(self, rng, sd, tau_s, x0=None):
        self.rng = rng
        self.sd = sd
        self.tau_s = tau_s
        self.x = rng.gauss(0.0, sd) if x0 is None else x0

    def step(self, dt_s):
        if self.sd <= 0.0:
            self.x = 0.0
            return 0.0
        a = math.exp(-dt_s / self.tau_s)
        self.x = a * self.x + self.sd * math.sqrt(1.0 - a * a) * self.rng.gauss(0.0, 1.0)
        return self.x
