"""The rollout layer: run any policy on any case, keep every episode, report like the paper.

Modules, in the order data flows through them:
- `policies/`: the protocol (`base`: reset with the instruction, observation in, chunk of 7-D
  actions out, optionally predicted frames; the infrastructure-error family) and its adapters (`reference`, `scripted`, `openpi`,
  `callable`); `wam`: the opt-in extension of openpi's protocol for world-action models (episode
  reset, predicted frames); `openpi_server`: a loopback server speaking openpi's protocol, with
  injectable faults, and a loopback world-action model. `spec` turns `--policy SPEC` into one.
- `case_env`: `env_for_case(case, trial, ...)`, the one place an episode's env comes from.
- `contacts`: gripper contact composition from MuJoCo contacts.
- `episode`: one closed-loop episode (wait steps, chunk execution, success, timeline, video).
- `jobs`: one episode as a job and its row, with bounded retries; `backends`: inline, local
  process pool, Ray; `runner`: plan, resume, dispatch, record; `store`: the SQLite results store.
- `progress`: the progress line; `metrics`, `report_tables`, `plots`, `report`: `vpro report`.
- `gym_env`: a gymnasium environment per case (`vpro/Case-v0`); `lerobot_layout`: its
  observations in LeRobot's LIBERO layout (`obs_layout="lerobot"`).
"""
