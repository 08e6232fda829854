"""The sections of docs/taxonomy.md that say how the cases are chosen: the allocation rule, the
counts the paper pins (with their tables), the meaningfulness rules and every setting's variants."""

from __future__ import annotations

from collections import Counter

from vpro_assets.benchmark import allocation, applicability
from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.benchmark.variants import FIXTURE_GOAL_DISTRACTORS, VARIANTS, setting_key, variants_of


def _fmt(value) -> str:
    return "-" if value is None else f"`{value}`"


def choice_section(catalog: dict) -> list[str]:
    """'How cases are chosen': the rule, the pinned counts and the applicability rules."""
    per_cat = Counter(c["category"] for c in catalog["cases"])
    lines = [
        "## How cases are chosen",
        "",
        (allocation.__doc__ or "")
        .strip()
        .split("\n", 1)[1]
        .strip()
        .replace("TOTAL_CASES", str(allocation.TOTAL_CASES)),
        "",
        "Counts the paper pins (`vpro_assets/benchmark/allocation.py`, `PINNED`):",
        "",
        "| category | cases | per setting | same tasks | read from |",
        "|---|---|---|---|---|",
    ]
    for pin in allocation.PINNED:
        split = ", ".join(f"{name} {n}" for name, n in pin.per_setting) or "even"
        lines.append(
            f"| {tx.category(pin.category).title} | {pin.cases} | {split} | {'yes' if pin.same_tasks else '-'} | "
            f"{pin.source} |"
        )
    rest = [c for c in tx.CATEGORIES if allocation.pinned(c.id) is None]
    lines += [
        "",
        f"The other {len(rest)} categories share {sum(per_cat[c.id] for c in rest)} cases: "
        + ", ".join(f"{c.title} {per_cat[c.id]}" for c in rest)
        + ".",
        "",
        "Rules:",
        "",
    ]
    lines += [f"- `{r.name}`: {r.text}" for r in applicability.RULES.values()]
    return lines


def variant_section(catalog: dict) -> list[str]:
    """'Variants': every further variant of a setting, its case-id suffix, rule, parameters and cases."""
    counts = Counter((c["setting"], c["params"].get("variant", "")) for c in catalog["cases"])
    lines = [
        "## Variants",
        "",
        "Where the paper's count for a setting is larger than its meaningful tasks, the setting has "
        "variants (`vpro_assets/benchmark/variants.py`): each is a case of its own whose id carries "
        "the variant's suffix, with its own parameters (`variant` names it). The base variant is the "
        "setting as defined above and keeps the plain case id.",
        "",
        "| setting | variant (id suffix) | rule | parameters | cases | what it is |",
        "|---|---|---|---|---|---|",
    ]
    for s in tx.SETTINGS:
        if setting_key(s) not in VARIANTS:
            continue
        for v in variants_of(s):
            rule = applicability.rule_for(s).name if v.rule is None else v.rule
            params = "<br>".join(f"{k}={_fmt(val)}" for k, val in v.params if k != "variant") or "(the setting's)"
            text = v.text or "The setting as defined."
            lines.append(
                f"| `{s.id}` | {f'`{v.suffix}`' if v.name else 'base'} | `{rule}` | {params} | "
                f"{counts[(s.id, v.name)]} | {text} |"
            )
    return [*lines, "", f"Distractors on fixture-only goals: {FIXTURE_GOAL_DISTRACTORS}"]
