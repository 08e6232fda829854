"""What every `vpro bench` writes: its section of docs/benchmarks.md and the machine it ran on."""

from __future__ import annotations

import os
from pathlib import Path

from vpro_assets.core import paths
from vpro_assets.core.atomic import write_text_atomic

DEFAULT_DOC = paths.REPO_ROOT / "docs" / "benchmarks.md"


def update_markdown_section(path: Path, name: str, body: str, title: str = "# Benchmarks") -> None:
    """Replace the section `name` (between BEGIN/END markers) of a Markdown file, or append it;
    other sections are kept byte for byte."""
    begin, end = f"<!-- BEGIN bench:{name} -->", f"<!-- END bench:{name} -->"
    block = f"{begin}\n{body.rstrip()}\n{end}\n"
    text = path.read_text() if path.exists() else f"{title}\n\n"
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        tail = rest.split(end, 1)[1].lstrip("\n")
        text = head + block + ("\n" + tail if tail else "")
    else:
        text = text.rstrip("\n") + "\n\n" + block
    write_text_atomic(path, text)


def cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
