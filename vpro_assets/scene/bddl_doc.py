"""BDDL documents: split LIBERO's base BDDL into its sections, fill the templates of
`bddl_templates/`, and check the result with LIBERO's own parser.

The base task's text is reused verbatim where the variant does not change it (language, goal,
region blocks, init predicates), so the written BDDL keeps the task's language and goal by
construction, and `check_variant` proves it with LIBERO's parser.
"""

from __future__ import annotations

import re
import string
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from bddl_templates import TEMPLATE_DIR
from vpro_assets.core.errors import VProError
from vpro_assets.libero import bridge as libero_bridge

SCENE_TEMPLATE = "scene_variant.bddl"
REGION_TEMPLATE = "region.bddl"
# Placeholders a scene template must contain: a template that lacks one would silently drop a
# section of the task.
REQUIRED_FIELDS = ("problem", "language", "regions", "fixtures", "objects", "obj_of_interest", "init", "goal")


class BDDLError(VProError):
    """A BDDL template or document that cannot be filled, parsed, or changes the task."""


@dataclass(frozen=True)
class Region:
    """A rectangle on a fixture (usually the workspace table), in LIBERO's region coordinates
    (relative to the workspace offset), with an optional fixed yaw range."""

    name: str
    target: str
    ranges: tuple[float, float, float, float]
    yaw: tuple[float, float] | None = None

    @property
    def full_name(self) -> str:
        return f"{self.target}_{self.name}"


@dataclass
class BaseBDDL:
    """The sections of a LIBERO BDDL file, as raw text where the variant keeps them."""

    text: str
    problem: str
    language: str  # raw text inside (:language ...)
    region_blocks: list[str]  # raw text of each region, in order
    fixtures: list[tuple[str, str]]  # (instance, category)
    objects: list[tuple[str, str]]
    obj_of_interest: list[str]
    init: list[str]  # raw predicates "(On a b)"
    goal: str  # raw text inside (:goal ...)
    parsed: dict = field(repr=False, default_factory=dict)


def _group_spans(text: str) -> list[tuple[int, int]]:
    """Spans of the parenthesised groups one level inside the outermost group of `text`."""
    depth, start, spans = 0, None, []
    for i, ch in enumerate(text):
        if ch == "(":
            depth += 1
            if depth == 2:
                start = i
        elif ch == ")":
            if depth == 2 and start is not None:
                spans.append((start, i + 1))
            depth -= 1
    return spans


def _top_groups(text: str) -> list[tuple[int, int]]:
    """Spans of the parenthesised groups directly inside `(define ...)`, comments ignored."""
    return _group_spans(re.sub(r";.*$", lambda m: " " * len(m.group(0)), text, flags=re.MULTILINE))


def _inner_groups(block: str) -> list[str]:
    """Raw text of the groups one level inside `block` (which starts with '(')."""
    return [block[a:b] for a, b in _group_spans(block)]


def _typed_list(block: str) -> list[tuple[str, str]]:
    body = block.strip()[1:-1].split(None, 1)[1] if len(block.strip()[1:-1].split(None, 1)) > 1 else ""
    out: list[tuple[str, str]] = []
    pending: list[str] = []
    tokens = body.split()
    i = 0
    while i < len(tokens):
        if tokens[i] == "-":
            out += [(inst, tokens[i + 1]) for inst in pending]
            pending, i = [], i + 2
        else:
            pending.append(tokens[i])
            i += 1
    return out


def read_base(path: Path | str) -> BaseBDDL:
    text = Path(path).read_text()
    sections: dict[str, str] = {}
    for a, b in _top_groups(text):
        block = text[a:b]
        head = block[1:].split(None, 1)[0].rstrip(")").lower()
        sections[head] = block
    try:
        problem = sections["problem"][1:-1].split()[1]
        language = sections[":language"][1:-1].split(None, 1)[1].strip()
        goal_block = sections[":goal"]
        goal = goal_block[goal_block.index("(", 1) : goal_block.rindex(")")].strip()
    except (KeyError, IndexError, ValueError) as exc:
        raise BDDLError(f"{path}: not a LIBERO BDDL problem (missing section {exc})") from None
    regions = _inner_groups(sections.get(":regions", "()"))
    return BaseBDDL(
        text=text,
        problem=problem,
        language=language,
        region_blocks=[" " * 6 + r for r in regions],
        fixtures=_typed_list(sections.get(":fixtures", "(:fixtures)")),
        objects=_typed_list(sections.get(":objects", "(:objects)")),
        obj_of_interest=sections.get(":obj_of_interest", "(:obj_of_interest)")[1:-1].split()[1:],
        init=[" ".join(g.split()) for g in _inner_groups(sections.get(":init", "(:init)"))],
        goal=goal,
        parsed=libero_bridge.bddl_parser().robosuite_parse_problem(str(path)),
    )


def _template(name: str, case_id: str, template_dir: Path | None = None) -> string.Template:
    path = Path(template_dir or TEMPLATE_DIR) / name
    try:
        return string.Template(path.read_text())
    except FileNotFoundError:
        raise BDDLError(f"case {case_id}: BDDL template {path} does not exist") from None


def _fill(template: string.Template, values: dict, case_id: str, name: str) -> str:
    try:
        return template.substitute(values)
    except KeyError as exc:
        raise BDDLError(
            f"case {case_id}: template {name} needs field {exc.args[0]!r}, which the generator "
            f"does not provide (provided: {', '.join(sorted(values))})"
        ) from None
    except ValueError as exc:
        raise BDDLError(f"case {case_id}: template {name} is malformed ({exc})") from None


def _num(x: float) -> str:
    return f"{x:.4f}".rstrip("0").rstrip(".") if x != 0 else "0.0"


def region_block(region: Region, case_id: str, template_dir: Path | None = None) -> str:
    x0, y0, x1, y1 = region.ranges
    if x1 < x0 or y1 < y0:
        raise BDDLError(f"case {case_id}: region {region.name} has inverted ranges {region.ranges}")
    yaw = region.yaw or (0.0, 0.0)
    text = _fill(
        _template(REGION_TEMPLATE, case_id, template_dir),
        {
            "name": region.name,
            "target": region.target,
            "x0": _num(x0),
            "y0": _num(y0),
            "x1": _num(x1),
            "y1": _num(y1),
            "yaw0": _num(yaw[0]),
            "yaw1": _num(yaw[1]),
        },
        case_id,
        REGION_TEMPLATE,
    )
    if region.yaw is None:  # drop the yaw block: LIBERO then uses its default (no rotation)
        text = re.sub(r"\n\s*\(:yaw_rotation \(\n.*?\n\s*\)\n\s*\)", "", text, flags=re.S)
    return text.rstrip("\n")


def _typed_lines(pairs: list[tuple[str, str]]) -> str:
    grouped: dict[str, list[str]] = {}
    for inst, cat in pairs:
        grouped.setdefault(cat, []).append(inst)
    return "\n".join(f"    {' '.join(insts)} - {cat}" for cat, insts in grouped.items())


def render_variant(
    base: BaseBDDL,
    *,
    case_id: str,
    generator: str,
    base_task: str,
    summary: str,
    objects: list[tuple[str, str]],
    fixtures: list[tuple[str, str]],
    regions: list[Region],
    init: list[str],
    template_dir: Path | None = None,
) -> str:
    """Fill the scene template. `objects`, `fixtures`, `init` are the variant's full lists;
    added regions are appended after the base task's own region blocks."""
    template = _template(SCENE_TEMPLATE, case_id, template_dir)
    present = {m.group("named") or m.group("braced") for m in template.pattern.finditer(template.template)}
    missing = [f for f in REQUIRED_FIELDS if f not in present]
    if missing:
        raise BDDLError(
            f"case {case_id}: template {SCENE_TEMPLATE} lacks field(s) {', '.join(missing)}; "
            "the written BDDL would drop part of the task"
        )
    values = {
        "case_id": case_id,
        "generator": generator,
        "base_task": base_task,
        "summary": " ".join(summary.split()),
        "problem": base.problem,
        "language": base.language,
        "regions": "\n".join(base.region_blocks + [region_block(r, case_id, template_dir) for r in regions]),
        "fixtures": _typed_lines(fixtures),
        "objects": _typed_lines(objects),
        "obj_of_interest": "\n".join(f"    {o}" for o in base.obj_of_interest),
        "init": "\n".join(f"    {p}" for p in init),
        "goal": base.goal,
    }
    return _fill(template, values, case_id, SCENE_TEMPLATE)


def parse_text(text: str, case_id: str) -> dict:
    """Parse BDDL text with LIBERO's own parser (it reads files, so through a temporary one)."""
    with tempfile.NamedTemporaryFile("w", suffix=".bddl", delete=True) as handle:
        handle.write(text)
        handle.flush()
        try:
            return libero_bridge.bddl_parser().robosuite_parse_problem(handle.name)
        except Exception as exc:  # LIBERO's parser raises bare Exceptions and asserts
            raise BDDLError(
                f"case {case_id}: LIBERO's parser rejects the written BDDL ({type(exc).__name__}: {exc})"
            ) from None


def check_variant(text: str, base: BaseBDDL, case_id: str) -> dict:
    """The written BDDL parses with LIBERO's parser and keeps the task's language and goal."""
    parsed = parse_text(text, case_id)
    for key in ("language_instruction", "goal_state", "problem_name", "obj_of_interest"):
        if parsed[key] != base.parsed[key]:
            raise BDDLError(
                f"case {case_id}: the written BDDL changes the task's {key}: {base.parsed[key]!r} -> {parsed[key]!r}"
            )
    return parsed
