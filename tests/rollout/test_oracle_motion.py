"""The hand's turn in place (`motion.turn_in_place`) ends at its tolerance, or, asked to, once it
stalls short of it: libero_spatial-04 multipeak-s1 trial 0's turn back upright (`level.upright`)
came to 3.4 degrees of its goal in 25 steps and swayed there, over the 2.9 it asks, until its 40
steps ran out (the trial then ended at the step limit).
"""

import numpy as np
from scipy.spatial.transform import Rotation

from vpro_assets.rollout.policies.oracle import motion


class _TurningHand:
    """A world whose hand turns about z, one angle per action taken (the last repeated)."""

    hold_grip = motion.CLOSE

    def __init__(self, degrees: list[float]):
        self.degrees, self.taken = degrees, 0

    def eef(self) -> np.ndarray:
        return np.zeros(3)

    def eef_mat(self) -> np.ndarray:
        angle = self.degrees[min(self.taken, len(self.degrees) - 1)]
        return Rotation.from_euler("z", angle, degrees=True).as_matrix()

    def turn(self, **options) -> int:
        """Take the turn's actions to the goal (no turn about z); how many there were."""
        for _ in motion.turn_in_place(self, np.eye(3), 40, **options):  # type: ignore[arg-type]
            self.taken += 1
        return self.taken


SETTLING = [20.6, 17.0, 14.2, 12.6, 10.9, 9.2, 8.2, 7.3, 6.4, 5.8, 5.3, 5.0, 4.7, 4.3, 4.1, 3.9, 3.8, 3.6, 3.5,
            3.4, 3.4, 3.5, 3.6, 3.4, 3.5, 3.6]  # fmt: skip


def test_a_turn_that_settles_short_of_its_tolerance_gives_up_once_it_stalls():
    """Settled at 3.4-3.6 degrees (TURN_TOL is 2.9): without stall steps the turn runs its 40 steps;
    with 5, it ends once the turn still to go shrank less than a degree in 5 steps (at 3.5)."""
    assert np.degrees(motion.TURN_TOL) < 3.4
    assert _TurningHand(SETTLING).turn() == 40
    taken = _TurningHand(SETTLING).turn(stall_steps=5)
    assert 18 <= taken <= 22, taken
    assert 3.3 < SETTLING[taken] < 4.0


def test_a_turn_that_reaches_its_tolerance_is_the_same_with_stall_steps():
    """A turn that keeps closing in (by 30% a step) ends at its tolerance, stall steps or not."""
    closing = list(20.0 * 0.7 ** np.arange(40))
    plain = _TurningHand(closing).turn()
    assert plain < 10 and closing[plain] < np.degrees(motion.TURN_TOL) <= closing[plain - 1]
    assert _TurningHand(closing).turn(stall_steps=5) == plain
