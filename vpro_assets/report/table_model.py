"""A report table as data (`Table` of `Cell`s: a success rate, its interval and its drop from
Normal), its Markdown and LaTeX renderings, and the helpers that make cells from episode rows."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.report.metrics import Rate, drop, rate

ROBUST_MARK, DIAG_MARK = "↑", "◇"
LATEX_MARKS = {tx.ROBUSTNESS: r"$\,\uparrow$", tx.DIAGNOSTIC: r"$\,\diamond$"}
LATEX_PREAMBLE = r"""% Macros used by these tables (redefine \ci as {} to hide intervals):
% \usepackage{xcolor}
\providecommand{\drop}[1]{{\color{gray}\scriptsize$\downarrow$#1}}
\providecommand{\gain}[1]{{\color{gray}\scriptsize$\uparrow$#1}}
\providecommand{\ci}[3]{{\tiny\,[#1,#2]\,n=#3}}
"""


@dataclass
class Cell:
    rate: Rate
    drop: float | None = None

    def markdown(self) -> str:
        if self.rate.sr is None or self.rate.ci is None:
            return "–" + (f" ({self.rate.errors} err)" if self.rate.errors else "")
        lo, hi = self.rate.ci
        d = "" if self.drop is None else (f" ↓{self.drop:.1f}" if self.drop >= 0 else f" ↑{-self.drop:.1f}")
        err = f", {self.rate.errors} err" if self.rate.errors else ""
        return f"{self.rate.sr:.1f}{d} (n={self.rate.trials}; {lo:.1f}–{hi:.1f}{err})"

    def latex(self) -> str:
        if self.rate.sr is None or self.rate.ci is None:
            return "--"
        lo, hi = self.rate.ci
        d = (
            ""
            if self.drop is None
            else (rf"\drop{{{self.drop:.1f}}}" if self.drop >= 0 else rf"\gain{{{-self.drop:.1f}}}")
        )
        return rf"{self.rate.sr:.2f}{d}\ci{{{lo:.1f}}}{{{hi:.1f}}}{{{self.rate.trials}}}"


@dataclass
class Table:
    key: str
    title: str
    columns: list[str]
    rows: list[list] = field(default_factory=list)  # first entry: row label; others Cell or str
    note: str = ""
    latex_columns: list[str] | None = None

    def markdown(self) -> str:
        out = [f"### {self.title}", ""]
        if self.note:
            out += [self.note, ""]
        out.append("| " + " | ".join(self.columns) + " |")
        out.append("|" + "|".join("---" for _ in self.columns) + "|")
        for row in self.rows:
            out.append("| " + " | ".join(c.markdown() if isinstance(c, Cell) else str(c) for c in row) + " |")
        return "\n".join(out) + "\n"

    def latex(self) -> str:
        cols = self.latex_columns or [_tex(c) for c in self.columns]
        lines = [
            r"\begin{table}[t]",
            rf"\caption{{{_tex(self.title)}}}",
            rf"\label{{tab:vpro_{self.key}}}",
            r"\centering",
            r"\scriptsize",
            r"\resizebox{\columnwidth}{!}{%",
            rf"\begin{{tabular}}{{l{'c' * (len(cols) - 1)}}}",
            r"\hline",
            " & ".join(cols) + r" \\",
            r"\hline",
        ]
        for row in self.rows:
            lines.append(" & ".join(c.latex() if isinstance(c, Cell) else _tex(str(c)) for c in row) + r" \\")
        lines += [r"\hline", r"\end{tabular}%", "}", r"\end{table}"]
        return "\n".join(lines) + "\n"


def _tex(text: str) -> str:
    for a, b in (
        ("\\", r"\textbackslash{}"),
        ("&", r"\&"),
        ("%", r"\%"),
        ("_", r"\_"),
        ("#", r"\#"),
        ("↑", r"$\uparrow$"),
        ("◇", r"$\diamond$"),
        ("↓", r"$\downarrow$"),
    ):
        text = text.replace(a, b)
    return text


@functools.cache
def params(setting_id: str) -> dict:
    try:
        return tx.setting(setting_id).param_dict
    except Exception:  # a setting of another taxonomy version: no parameters to group by
        return {}


def policies(rows: list[dict]) -> list[str]:
    return sorted({r["policy_id"] for r in rows})


def cell(cell_rows: list[dict], policy_rows: list[dict]) -> Cell:
    return Cell(rate(cell_rows), drop(cell_rows, policy_rows))
