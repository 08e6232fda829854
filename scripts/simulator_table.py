"""The settle table of docs/simulator.md from `vpro settle --json` files of several simulators.

    .venv/bin/python scripts/simulator_table.py REFERENCE.json OTHER.json [OTHER.json ...]

One row per case: for each file, the trials whose start has a problem (`settle.trial_problems`:
an object off the table or out of view, moving faster than the limit, an :init relation broken),
and for each other file the largest displacement (cm) and tilt change (deg) against the reference
over the trials both files hold."""

from __future__ import annotations

import json
import sys
from collections import defaultdict
from pathlib import Path

from vpro_assets.libero.settled import pose_difference
from vpro_assets.rollout.settle import trial_problems


def _short(problem: str) -> str:
    return problem.replace(" at the first frame", "").replace("living_room_table_", "").replace("main_table_", "")


def main(paths: list[str]) -> None:
    runs = [json.loads(Path(p).read_text()) for p in paths]
    names = [f"mujoco {r['simulator']['mujoco']}" for r in runs]
    by_key = [{(rec["case"], rec["trial"]): rec for rec in r["records"]} for r in runs]
    cases = list(dict.fromkeys(rec["case"] for rec in runs[0]["records"]))
    head = ["case"] + [f"{n}: problems" for n in names] + [f"{n} vs {names[0]}: cm / deg" for n in names[1:]]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for cid in cases:
        cells = [cid.replace("/normal", "")]
        for keyed in by_key:
            found = defaultdict(list)
            for (c, t), rec in sorted(keyed.items()):
                if c == cid:
                    for p in trial_problems(rec):
                        found[_short(p)].append(t)
            cells.append("; ".join(f"{p} (trial {', '.join(map(str, ts))})" for p, ts in found.items()) or "-")
        for keyed in by_key[1:]:
            diffs = [pose_difference(by_key[0][k], keyed[k]) for k in by_key[0] if k[0] == cid and k in keyed]
            worst = max(diffs, key=lambda d: d["displacement_cm"])
            tilt = max(d["tilt_deg"] for d in diffs)
            cells.append(f"{worst['displacement_cm']:.2f} {worst['object'] or ''} / {tilt:.1f}")
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
