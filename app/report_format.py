"""What the report's pages share: a Markdown table, a plain log axis, a figure saved whole."""
from __future__ import annotations

from pathlib import Path

from app.image_io import atomic_path


def markdown_table(header: list[str], rows: list[list[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "|".join(" --- " for _ in header) + "|"]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out


def plain_log_ticks(axis) -> None:
    """A log axis labelled 20, 30, 50, 100, ... (not 2 x 10^1, overlapping at every minor tick)."""
    import matplotlib.ticker

    plain = matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}")
    axis.set_major_formatter(plain)
    axis.set_minor_locator(matplotlib.ticker.LogLocator(subs=(2.0, 3.0, 5.0)))
    axis.set_minor_formatter(plain)


def save_figure(fig, path: Path) -> str:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    return path.name
