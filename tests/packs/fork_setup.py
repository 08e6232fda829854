"""What a fork's own scripts do before building a LIBERO env, shared by the scripts run inside the
fork venvs (tests/packs/fork_obs_check.py, fork_drift_check.py). Imports only the fork's packages."""

import robosuite


def fork_setup() -> str:
    """The fork's set-up line; returns robosuite's version."""
    if tuple(int(p) for p in robosuite.__version__.split(".")[:2]) >= (1, 5):
        # rpent-libero's OnTheGround robots declare no base (`default_base` None); robosuite 1.5 looks
        # the base up in BASE_MAPPING. The fork's users add this line; it is the fork's, not the pack's.
        from robosuite.models.bases import BASE_MAPPING
        from robosuite.models.bases.null_mount import NullMount

        BASE_MAPPING.setdefault(None, NullMount)
    return robosuite.__version__
