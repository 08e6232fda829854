"""PNG figures for `vpro report` (matplotlib, Agg backend, loaded lazily).

- `categories.png`: SR per category per policy with 95% intervals; robustness categories solid,
  diagnostic ones hatched, Normal as a dashed line.
- `contact_composition.png`: stacked bars of contact composition per distractor type.
- `phase_corruption.png`: SR by corruption trigger phase.
"""

from __future__ import annotations

from pathlib import Path

from vpro_assets.benchmark import taxonomy as tx
from vpro_assets.core.errors import VProError
from vpro_assets.report.metrics import composition, group, normal_rate, rate
from vpro_assets.report.tables import params, policies
from vpro_assets.rollout.contacts import COMPOSITIONS


def _plt():
    try:
        import matplotlib
    except ImportError:
        raise VProError("plots need matplotlib: pip install 'libero-vpro[plots]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _bars(ax, labels, series, hatches=None):
    import numpy as np

    width = 0.8 / max(1, len(series))
    x = np.arange(len(labels))
    for i, (name, rates) in enumerate(series.items()):
        srs = [r.sr if r.sr is not None else 0.0 for r in rates]
        err = [
            [(r.sr - r.ci[0]) if r.sr is not None else 0 for r in rates],
            [(r.ci[1] - r.sr) if r.sr is not None else 0 for r in rates],
        ]
        bars = ax.bar(x + i * width - 0.4 + width / 2, srs, width, yerr=err, capsize=2, label=name)
        for bar, hatch in zip(bars, hatches or []):
            bar.set_hatch(hatch)
    ax.set_xticks(x)
    ax.set_xticklabels(labels, rotation=35, ha="right", fontsize=7)
    ax.set_ylim(0, 105)
    ax.set_ylabel("success rate (%)")


# Long on purpose: one block per figure, in the order the report shows them.
def write_plots(rows: list[dict], out: Path) -> list[Path]:
    plt = _plt()
    out.mkdir(parents=True, exist_ok=True)
    written = []
    pids = policies(rows)

    cats = [c for c in tx.CATEGORIES if any(r["category"] == c.id for r in rows)]
    fig, ax = plt.subplots(figsize=(max(6, 1.0 * len(cats) + 2), 4))
    series = {
        pid: [rate(r for r in rows if r["policy_id"] == pid and r["category"] == c.id) for c in cats] for pid in pids
    }
    _bars(
        ax,
        [f"{c.title} {'↑' if c.indicator == tx.ROBUSTNESS else '◇'}" for c in cats],
        series,
        ["" if c.indicator == tx.ROBUSTNESS else "//" for c in cats],
    )
    for pid in pids:
        base = normal_rate([r for r in rows if r["policy_id"] == pid])
        if base.sr is not None:
            ax.axhline(base.sr, linestyle="--", linewidth=1, color="gray")
    ax.set_title("Success rate per category (↑ robustness, ◇ diagnostic hatched; dashed: Normal)", fontsize=9)
    if pids:
        ax.legend(fontsize=7)
    fig.tight_layout()
    written.append(_save(fig, out / "categories.png", plt))

    kinds = list(tx.DISTRACTOR_RULES)
    fig, axes = plt.subplots(1, max(1, len(pids)), figsize=(5 * max(1, len(pids)), 3.5), squeeze=False)
    for ax, pid in zip(axes[0], pids or ["-"]):
        by = group(
            [r for r in rows if r["policy_id"] == pid and r["category"] == "task_relevant_distractors"],
            lambda r: params(r["setting"]).get("distractor"),
        )
        bottom = [0.0] * len(kinds)
        for comp in COMPOSITIONS:
            vals = []
            for kind in kinds:
                counts = composition(by.get(kind, []))
                n = sum(counts.values())
                vals.append(100 * counts[comp] / n if n else 0.0)
            ax.bar(range(len(kinds)), vals, bottom=bottom, label=comp.replace("_", " "))
            bottom = [b + v for b, v in zip(bottom, vals)]
        ax.set_xticks(range(len(kinds)))
        ax.set_xticklabels([k.replace("_", " ") for k in kinds], rotation=35, ha="right", fontsize=7)
        ax.set_ylim(0, 100)
        ax.set_title(f"contact composition: {pid}", fontsize=9)
        ax.legend(fontsize=6)
    fig.tight_layout()
    written.append(_save(fig, out / "contact_composition.png", plt))

    fig, ax = plt.subplots(figsize=(5, 3.5))
    cat = [r for r in rows if r["category"] == "temporary_observation_corruption"]
    series = {
        pid: [
            rate(r for r in cat if r["policy_id"] == pid and params(r["setting"]).get("phase") == p) for p in tx.PHASES
        ]
        for pid in pids
    }
    _bars(ax, list(tx.PHASES), series)
    ax.set_title("Success rate under phase-triggered corruption", fontsize=9)
    if pids:
        ax.legend(fontsize=7)
    fig.tight_layout()
    written.append(_save(fig, out / "phase_corruption.png", plt))
    return written


def _save(fig, path: Path, plt) -> Path:
    tmp = path.with_name(f".{path.stem}.tmp.png")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(path)
    return path
