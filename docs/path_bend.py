"""How far a crowd's own path bends over the span a crowd's scatter is measured on (a diagnostic for
docs/results-worlds.md, session 47; not part of the product): per recording, the true crowd centre's
scatter (1 sigma per axis) about a straight line, a quadratic and a cubic in time fitted over each 10 s
window (every tenth frame from the tenth second), the median and 90th percentile per scenario.

    .venv/bin/python docs/path_bend.py OUT_DIR/<scenario>__seed<N>.pkl ...

The recordings are `docs/grouping_replay.py record`'s; frames with one true crowd.
"""

import os
import pickle
import sys
from collections import defaultdict

import numpy as np

WINDOW_S = 10.0     # uvteam.crowds.GroupingConfig.scatter_s


def main(paths: list[str]) -> None:
    out: dict[str, dict[int, list[float]]] = defaultdict(lambda: defaultdict(list))
    for path in paths:
        with open(path, "rb") as f:
            rec = pickle.load(f)
        frame, pts = rec["frame"], []
        for kind, _, b in rec["events"]:
            if kind == "truth" and len(b.crowds) == 1:
                e, n = frame.wgs84_to_ground(np.array([b.crowds[0].lat_deg]), np.array([b.crowds[0].lon_deg]))
                pts.append((b.stamp_s, e[0], n[0]))
        a = np.array(pts)
        world = os.path.basename(path).split("__")[0]
        for i in range(100, len(a), 10):
            seg = a[(a[:, 0] > a[i, 0] - WINDOW_S) & (a[:, 0] <= a[i, 0])]
            t = seg[:, 0] - seg[:, 0].mean()
            for deg in (1, 2, 3):
                V = np.vander(t / np.abs(t).max(), deg + 1)
                coef = np.linalg.lstsq(V, seg[:, 1:], rcond=None)[0]
                r = seg[:, 1:] - V @ coef
                out[world][deg].append(float(np.sqrt((r * r).sum() / (2 * (len(seg) - deg - 1)))))
    for world, by_deg in sorted(out.items()):
        print(f"{world:32s} " + "  ".join(f"{('line', 'quadratic', 'cubic')[d - 1]} {np.median(v):.3f} m "
                                          f"(p90 {np.percentile(v, 90):.3f})" for d, v in by_deg.items()))


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
