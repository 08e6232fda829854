"""Seeds derived from names, never from global state.

Every random draw in the toolkit comes from a `numpy.random.Generator` made here from a case id,
a trial and a component name, so changing one component never shifts another's draws.
"""

from __future__ import annotations

import hashlib

import numpy as np

SEED_SCHEME = "sha256('vpro-v1|' + '|'.join(parts)), first 8 bytes big-endian, modulo 2**31"
TRIALS_PER_CASE = 10


def derive_seed(*parts: object) -> int:
    digest = hashlib.sha256(("vpro-v1|" + "|".join(str(p) for p in parts)).encode()).digest()
    return int.from_bytes(digest[:8], "big") % (2**31)


def trial_seeds(case_id: str, trials: int = TRIALS_PER_CASE) -> list[int]:
    return [derive_seed(case_id, "trial", k) for k in range(trials)]


def rng(case_id: str, trial: int, component: str) -> np.random.Generator:
    """The random stream of one component (e.g. 'corruption') in one trial of one case."""
    return np.random.default_rng(derive_seed(case_id, "trial", trial, component))
