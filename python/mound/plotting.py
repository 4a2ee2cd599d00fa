"""matplotlib as the stages draw with it: the headless Agg backend chosen here, once (a
module that draws takes `plt` from here), and saving a figure."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

__all__ = ["plt", "save_figure"]


def save_figure(fig: plt.Figure, out_png: str | Path, dpi: int) -> Path:
    """`fig` laid out tightly and written to `out_png` (its folder made), then closed."""
    fig.tight_layout()
    out_png = Path(out_png)
    out_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=dpi)
    plt.close(fig)
    return out_png
