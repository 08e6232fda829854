"""`python -m vpro_assets.integrations.vla_eval [NAME]`: the path of a shipped vla-eval config (all without NAME)."""

from __future__ import annotations

import sys

from vpro_assets.core.errors import VProError
from vpro_assets.integrations.vla_eval import config_names, config_path


def main(argv: list[str]) -> int:
    try:
        names = argv or config_names()
        for name in names:
            print(config_path(name))  # noqa: T201 - the command's output
    except VProError as exc:
        print(f"error: {exc}", file=sys.stderr)  # noqa: T201
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
