"""The bridge to LIBERO: locating and importing it without prompts, its GL backend, its 40 tasks, initial states and envs."""
