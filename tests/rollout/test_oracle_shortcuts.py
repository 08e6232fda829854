"""The oracle's and the episode runner's shortcuts give exactly what the plain computation gives.

The certificate replays trials to their recorded final-state fingerprints, so a shortcut that
changed one comparison would change an action and, some steps later, a fingerprint: each is held
here to the computation it replaces (on random boxes, or on a real scene), bit for bit.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from conftest import catalog_case

from vpro_assets.perturb.entities import EntityIndex
from vpro_assets.perturb.phases import PhaseTracker
from vpro_assets.rollout.contacts import ContactTracker
from vpro_assets.rollout.episode import EpisodeSession, EpisodeSettings
from vpro_assets.rollout.policies.oracle.policy import OraclePolicy


class _IsinPhaseTracker(PhaseTracker):
    """The phase tracker as it was: the entities' geoms as id arrays, np.isin at every test."""

    def _geom_masks(self):
        ent, ids = self.entities, (lambda geoms: np.asarray(geoms, np.int32))
        obj = ids(ent.interaction.geoms)
        receptacle = ids(ent.receptacle.geoms if ent.receptacle is not None else [])
        left, right = ids(ent.left_finger_geoms), ids(ent.right_finger_geoms)
        return SimpleNamespace(
            obj_geoms=obj, obj=obj, gripper=ids(ent.gripper.geoms), left=left, right=right, receptacle=receptacle
        )

    @staticmethod
    def _touch(g1, g2, a, b) -> bool:
        if len(a) == 0 or len(b) == 0 or len(g1) == 0:
            return False
        return bool(np.any((np.isin(g1, a) & np.isin(g2, b)) | (np.isin(g1, b) & np.isin(g2, a))))


def _contacts_update_plain(tracker: ContactTracker, step: int) -> None:
    """`ContactTracker.update` as it was: contact by contact, every step."""
    data = tracker.sim.data
    for i in range(int(data.ncon)):
        a, b = int(data.contact[i].geom1), int(data.contact[i].geom2)
        other = b if a in tracker.gripper else a if b in tracker.gripper else None
        if other is None:
            continue
        if tracker.first_target is None and other in tracker.target:
            tracker.first_target = step
        if tracker.first_distractor is None and other in tracker.distractor:
            tracker.first_distractor = step


def test_the_runners_trackers_on_an_oracle_episode_agree_with_their_plain_forms():
    """The episode runner's phase tracker and contact tracker test contacts through boolean masks
    over the model's geoms (the contact tracker stops once it knows both first steps): on libero_10-00's
    whole oracle episode, not observed (as `vpro certify` runs it), with the second can counted as a
    distractor, the phase history, onsets and first contacts of the plain forms, step for step."""
    case = catalog_case("libero_10-00/normal")
    session = EpisodeSession(case, 0, EpisodeSettings(render=False), observe=False)
    policy = OraclePolicy()
    policy.reset(session.episode_info())
    plain: list[_IsinPhaseTracker] = []

    def on_reset(cenv) -> None:  # right after the reset's own tracker update: both trackers from here on
        policy.bind_env(cenv)
        plain.append(_IsinPhaseTracker(EntityIndex(cenv.sim, cenv.task)))
        plain[0].reset()
        plain[0].update(cenv.sim)
        tracker = cenv.tracker
        cenv.tracker = SimpleNamespace(update=lambda sim: (plain[0].update(sim), tracker.update(sim)), tracker=tracker)

    try:
        session.start(on_reset=on_reset)
        cenv = session.env
        pair = [ContactTracker(cenv.sim, "alphabet_soup_1", ["tomato_sauce_1"]) for _ in range(2)]
        while not session.finished:
            session.step(policy.next_action())
            pair[0].update(session.t)
            _contacts_update_plain(pair[1], session.t)
            assert (pair[0].first_target, pair[0].first_distractor) == (pair[1].first_target, pair[1].first_distractor)
        assert session.success
        tracker = cenv.tracker.tracker
        assert len(tracker.history) == session.t + 1 and tracker.history == plain[0].history
        assert tracker.timeline() == plain[0].timeline() and tracker.grasp_onset is not None
        assert pair[0].composition == "both" and pair[0].summary() == pair[1].summary()
    finally:
        session.close()
