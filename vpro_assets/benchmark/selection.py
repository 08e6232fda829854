"""`--select FILTER`: pick cases from the catalog by case id, setting, category, dimension,
suite or task (repeatable; several filters are a union). `normal` selects the Normal baselines,
narrowed by any suite or task filters given with it."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from vpro_assets.core.errors import UnknownIdError

NORMAL = "normal"


def _keys(case: dict) -> set[str]:
    setting = case.get("setting")
    keys = {case["id"], case["suite"], case["task"], case.get("task_name", "")}
    if setting:
        keys |= {setting, setting.removeprefix("vpro/"), case["category"], case["dimension"]}
    return keys


def known_filters(catalog: dict) -> set[str]:
    known = {NORMAL}
    for case in catalog["cases"] + catalog.get("normal", []):
        known |= _keys(case)
    return known


def select_cases(catalog: dict, filters: Sequence[str] | None) -> list[dict]:
    """Cases matching any filter, in catalog order; no filter means every case (not Normal)."""
    filters = [f.strip() for f in (filters or []) if f.strip()]
    if not filters:
        return list(catalog["cases"])
    known = known_filters(catalog)
    for f in filters:
        if f not in known:
            raise UnknownIdError("case, setting, category, dimension, suite or task", f, sorted(known))
    wanted = set(filters)
    normal = catalog.get("normal", [])
    picked_normal = [c for c in normal if c["id"] in wanted]  # a Normal baseline named by its id
    rest = wanted - {c["id"] for c in picked_normal}
    if NORMAL in rest:
        rest.discard(NORMAL)
        # Suites and tasks given with `normal` narrow the baselines and do not add perturbed cases.
        narrowing = rest & ({c["suite"] for c in normal} | {c["task"] for c in normal})
        picked_normal += [c for c in normal if (not narrowing or narrowing & _keys(c)) and c not in picked_normal]
        rest -= narrowing
    return picked_normal + [c for c in catalog["cases"] if rest & _keys(c)]


def describe(cases: Iterable[dict]) -> str:
    cases = list(cases)
    return f"{len(cases)} case(s) over {len({c['task'] for c in cases})} task(s)"
