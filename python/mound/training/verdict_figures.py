"""The verdict's figures: the reliability diagram with the detection limit (`figure`) and
the detection rate over height x diameter per grid (`detection_figure`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mound.training.verdict_data import DIAMETER_BINS, HEIGHT_BINS

if TYPE_CHECKING:
    from mound.training.verdict_eval import VerdictReport


def figure(report: VerdictReport, out: str | Path) -> None:
    """Reliability diagram and the detection rate over height x diameter."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.6))
    rel = [r for r in report["reliability"] if r["count"]]
    a.plot([0, 1], [0, 1], color="0.6", lw=1)
    a.plot([r["mean_p"] for r in rel], [r["observed"] for r in rel], "o-", color="C0")
    for r in rel:
        a.annotate(str(r["count"]), (r["mean_p"], r["observed"]), fontsize=7,
                   xytext=(3, -9), textcoords="offset points")
    a.set_xlabel("predicted p(mound)")
    a.set_ylabel("observed share of mounds")
    a.set_title(f"held-out reliability: ECE {report['ece']:.3f}, Brier {report['brier']:.3f}")
    tab = report["detection_limit"]["table"]
    nh, nd = len(HEIGHT_BINS) - 1, len(DIAMETER_BINS) - 1
    rate = np.full((nh, nd), np.nan)
    for k, c in enumerate(tab):
        if c["mounds"]:
            rate[k // nd, k % nd] = c["detected"] / c["mounds"]
    im = b.imshow(rate, origin="lower", cmap="RdYlGn", vmin=0, vmax=1, aspect="auto")
    for k, c in enumerate(tab):
        if c["mounds"]:
            b.text(k % nd, k // nd, f"{c['detected']}/{c['mounds']}", ha="center",
                   va="center", fontsize=8)
    b.set_xticks(range(nd), [f"{DIAMETER_BINS[j]:g}-{DIAMETER_BINS[j + 1]:g}"
                             for j in range(nd)])
    b.set_yticks(range(nh), [f"{HEIGHT_BINS[i]:g}-{HEIGHT_BINS[i + 1]:g}" for i in range(nh)])
    b.set_xlabel("diameter, m")
    b.set_ylabel("height, m")
    fa = report["goal_no_mound"]
    b.set_title(f"detected (held-out mounds); false alarms {fa['false_alarms']}/{fa['sites']}")
    fig.colorbar(im, ax=b, fraction=0.046)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def detection_figure(panels: list[tuple[str, VerdictReport]], out: str | Path) -> None:
    """The detection rate over height x diameter, one panel per grid (its label, its
    report), with each grid's false alarms and detection limit in the title."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    nh, nd = len(HEIGHT_BINS) - 1, len(DIAMETER_BINS) - 1
    cols = min(3, len(panels))
    rows = -(-len(panels) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 4.6 * rows), squeeze=False)
    for ax in axes.flat[len(panels):]:
        ax.axis("off")
    for ax, (label, rep) in zip(axes.flat, panels, strict=False):
        rate = np.full((nh, nd), np.nan)
        for k, c in enumerate(rep["detection_limit"]["table"]):
            if c["mounds"]:
                rate[k // nd, k % nd] = c["detected"] / c["mounds"]
                ax.text(k % nd, k // nd, f"{c['detected']}/{c['mounds']}", ha="center",
                        va="center", fontsize=8)
        ax.imshow(rate, origin="lower", cmap="RdYlGn", vmin=0, vmax=1, aspect="auto")
        ax.set_xticks(range(nd), [f"{DIAMETER_BINS[j]:g}-{DIAMETER_BINS[j + 1]:g}"
                                  for j in range(nd)])
        ax.set_yticks(range(nh), [f"{HEIGHT_BINS[i]:g}-{HEIGHT_BINS[i + 1]:g}"
                                  for i in range(nh)])
        ax.set_xlabel("diameter, m")
        ax.set_ylabel("height, m")
        fa = rep["goal_no_mound"]
        lim = rep["detection_limit"]["limit"] or []
        ax.set_title(f"{label}\nfalse alarms {fa['false_alarms']}/{fa['sites']}; >= 95 % from "
                     + (", ".join(f"{c['height_m_at_least']:g} m x {c['diameter_m_at_least']:g} m"
                                  for c in lim) or "none"), fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)
