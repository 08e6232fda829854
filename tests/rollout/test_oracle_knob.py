"""Stove knobs turned on, checked with LIBERO's TurnOn predicate (render-free).

Each skill test runs one skill alone from a task's first initial state (the `scene` fixture) and
checks LIBERO's own predicate, not the skill's opinion of itself.
"""

from vpro_assets.rollout.policies.oracle import knob


def test_knob_turns_the_stove_on(scene):
    s = scene("libero_goal-07/normal")
    joint = s.world.joints_of("flat_stove_1")[0]
    assert not s.holds(("turnon", "flat_stove_1"))
    s.run(knob.switch(s.world, "flat_stove_1", on=True), limit=200)
    assert s.world.qpos(joint) >= 0.5  # LIBERO's FlatStove: on from 0.5 rad
    assert s.holds(("turnon", "flat_stove_1")) and s.cenv.success()
