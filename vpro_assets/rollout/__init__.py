"""The rollout layer: run any policy on any case, keep every episode, report like the paper.

Modules, in the order data flows through them:
- `policy`: the policy protocol (reset with the instruction, observation in, chunk of 7-D actions
  out, optionally predicted frames) and the infrastructure-error family.
- `reference`, `openpi_adapter`, `callable_adapter`: adapters; `spec` turns `--policy SPEC` into one.
- `case_env`: `env_for_case(case, trial, ...)`, the one place an episode's env comes from.
- `contacts`: gripper contact composition from MuJoCo contacts.
- `episode`: one closed-loop episode (wait steps, chunk execution, success, timeline, video).
- `store`: the SQLite results store (WAL, one row per run, case and trial).
- `backends`: the local process pool and Ray; `runner`: plan, dispatch, retry, record.
- `progress`: the progress line; `metrics`, `report_tables`, `plots`: `vpro report`.
- `gym_env`: a gymnasium environment per case.
"""
