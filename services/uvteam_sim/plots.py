"""PNG plots of an experiment, one per figure of the seed paper (needs the ``plots`` extra: matplotlib).

- Fig. 7: altitude (paper-fig7-alt200 vs paper-fig7-alt50);
- Fig. 8: number of landmarks (paper-fig8-lm4 vs paper-fig8-lm6);
- Fig. 9: landmark image coordinates, color vs motion (paper-fig9-color-lmN beside paper-fig8-lmN, the
  same scenario with motion-blob coordinates);
- any other scenario (e.g. field-*) on a figure of its own.

Each figure has two panels: the error over time (mean over seeds in 0.5 s bins, shaded +-1 standard
deviation) per variant, and the mean error with its standard deviation per variant beside the
paper's mean where the paper gives one.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

__all__ = ["write_plots", "FIGURES"]

FIGURES = {
    "fig7": ("Fig. 7: UAV altitude", ["paper-fig7-alt200", "paper-fig7-alt50"]),
    "fig8": ("Fig. 8: number of landmarks", ["paper-fig8-lm4", "paper-fig8-lm6"]),
    "fig9": ("Fig. 9: landmark image coordinates (color vs motion)",
             ["paper-fig8-lm4", "paper-fig9-color-lm4", "paper-fig8-lm6", "paper-fig9-color-lm6"]),
}
BIN_S = 0.5


def _series(results) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.concatenate([np.asarray(r.times_s, float) for r in results]) if results else np.empty(0)
    e = np.concatenate([np.asarray(r.errors_m, float) for r in results]) if results else np.empty(0)
    if not len(t):
        return np.empty(0), np.empty(0), np.empty(0)
    bins = np.floor(t / BIN_S).astype(int)
    ub = np.unique(bins)
    mean = np.array([e[bins == b].mean() for b in ub])
    std = np.array([e[bins == b].std() for b in ub])
    return (ub + 0.5) * BIN_S, mean, std


def _label(name: str, sc) -> str:
    return f"{name} ({sc.landmarks.image_coordinates} landmarks)" if sc is not None else name


def write_plots(per: dict, scenarios: list, out: Path, detector: str = "") -> list[Path]:
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    by_name = {sc.name: sc for sc in scenarios}
    groups = []
    used = set()
    for key, (title, names) in FIGURES.items():
        present = [n for n in names if n in per]
        if len(present) >= 2 or (present and key != "fig9"):
            groups.append((key, title, present))
            used.update(present)
    for name in per:
        if name not in used:
            groups.append((name, name, [name]))
    paths = []
    for key, title, names in groups:
        fig, (ax_t, ax_b) = plt.subplots(1, 2, figsize=(12, 4.2), gridspec_kw={"width_ratios": [2.2, 1]})
        means, stds, papers, labels = [], [], [], []
        for n in names:
            sc = by_name.get(n)
            t, m, s = _series(per[n])
            line, = ax_t.plot(t, m, label=_label(n, sc))
            ax_t.fill_between(t, np.maximum(m - s, 0), m + s, color=line.get_color(), alpha=0.2)
            e = np.concatenate([np.asarray(r.errors_m, float) for r in per[n]]) if per[n] else np.empty(0)
            means.append(e.mean() if len(e) else math.nan)
            stds.append(e.std() if len(e) else math.nan)
            papers.append(sc.paper_mean_error_m if sc is not None else math.nan)
            labels.append(n.replace("paper-", "") + ("\n" + sc.landmarks.image_coordinates if sc is not None else ""))
        ax_t.set_xlabel("time (s)")
        ax_t.set_ylabel("error (m)")
        ax_t.set_title(f"{title}: error over time ({detector}, mean over seeds, +-1 sd)")
        ax_t.grid(alpha=0.3)
        ax_t.legend(fontsize=8)
        x = np.arange(len(names))
        ax_b.bar(x - 0.2, means, 0.4, yerr=stds, capsize=4, label="uvteam mean +- sd")
        if any(np.isfinite(papers)):
            ax_b.bar(x + 0.2, [p if np.isfinite(p) else 0 for p in papers], 0.4, color="0.6", label="paper mean")
        ax_b.set_xticks(x, labels, fontsize=8)
        ax_b.set_ylabel("error (m)")
        ax_b.set_title("mean and variance per variant")
        ax_b.grid(axis="y", alpha=0.3)
        ax_b.legend(fontsize=8)
        fig.tight_layout()
        path = Path(out) / f"{key}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths
