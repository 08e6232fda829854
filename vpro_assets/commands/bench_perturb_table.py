"""The Markdown table of `vpro bench perturb`: one line per setting, then the categories' medians."""

from __future__ import annotations

import statistics

GOAL_OTHER, GOAL_MASK = 1.02, 1.05
CONTROL = "control (identity pipeline)"


def markdown_table(rows: list[dict], meta: dict) -> str:
    lines = [
        "### Observation perturbations: step time against the clean env (`vpro bench perturb`)",
        "",
        f"Measured {meta['date']} on {meta['machine']} with `{meta.get('command', 'vpro bench perturb')}`: "
        f"{meta['steps']} scripted steps per block at {meta['resolution']} px, clean and perturbed blocks "
        f"interleaved, the whole sequence repeated {meta.get('rounds', 1)} times (wall {meta.get('wall', '?')}; "
        f"load average {meta.get('load', '?')}). "
        "ratio = median perturbed step / median step of the neighbouring clean blocks, pooled over the rounds "
        "(wall clock: includes the noise of the machine's load); range = lowest and highest per-round ratio; "
        "the control row is an identity pipeline measured the same way (the noise floor); "
        "overhead = 1 + the pipeline's own added work per step (observe, scene edits and scene captures, timed "
        f"directly) / the clean step. Goal: <= {GOAL_MASK} for mask settings, <= {GOAL_OTHER} for the others. "
        "`active` = steps on which the setting changed something (schedules and phases decide; blocks start "
        "from the initial state, so settings that wait for a grasp or a placement seldom act in them).",
        "",
        "| setting | task | masks | clean ms | perturbed ms | ratio | range | added ms | overhead | active | "
        "goal met (ratio / overhead) |",
        "|---|---|---|---:|---:|---:|---|---:|---:|---:|---|",
    ]
    for r in rows:
        met = (
            ""
            if r["setting"] == CONTROL
            else (
                f"{'yes' if r['meets_goal'] else '**no**'} / "
                f"{'yes' if r.get('overhead_meets_goal', r['meets_goal']) else '**no**'}"
            )
        )
        rng = f"{r['ratio_min']:.3f}-{r['ratio_max']:.3f}" if "ratio_min" in r else ""
        masks = {"capture": "yes", "reference": "yes, full-scene segmentation"}.get(str(r.get("mask_path")), "no")
        lines.append(
            f"| `{r['setting']}` | {r['task']} | {masks} | "
            f"{r['clean_step_ms']:.0f} | {r['perturbed_step_ms']:.0f} | {r['ratio']:.3f} | {rng} | "
            f"{r.get('added_ms', 0):.1f} | {r.get('overhead_ratio', r['ratio']):.3f} | "
            f"{r['active_steps']}/{r.get('measured_steps', r['steps'])} | {met} |"
        )
    by_cat: dict[str, list[dict]] = {}
    for r in rows:
        by_cat.setdefault(
            r["category"] + (" (full-scene segmentation)" if r.get("mask_path") == "reference" else ""), []
        ).append(r)
    lines += [
        "",
        "| category | settings | median ratio | max ratio | median overhead | max overhead | goal | "
        "met (ratio / overhead) |",
        "|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for cat, rs in by_cat.items():
        ratios = [r["ratio"] for r in rs]
        over = [r.get("overhead_ratio", r["ratio"]) for r in rs]
        goal = rs[0].get("goal", "")
        met = (
            ""
            if cat == "control"
            else f"{sum(r['meets_goal'] for r in rs)}/{len(rs)} / {sum(r.get('overhead_meets_goal', True) for r in rs)}/{len(rs)}"
        )
        lines.append(
            f"| {cat} | {len(rs)} | {statistics.median(ratios):.3f} | {max(ratios):.3f} | "
            f"{statistics.median(over):.3f} | {max(over):.3f} | {goal if cat != 'control' else ''} | {met} |"
        )
    return "\n".join(lines) + "\n"
