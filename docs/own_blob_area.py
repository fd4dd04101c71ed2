"""The ground area (m2) of the blob the localizer pairs with each UGV, by the UGV's reported speed, over the
first T seconds of a run: what a vehicle's own blob looks like, for ``LocalizerConfig.min_vehicle_blob_m2``
(docs/results-worlds.md, session 26). A diagnostic, not part of the product.

    .venv/bin/python docs/own_blob_area.py scenarios/real-alt60-lm6.toml 1 40
"""

import sys

import numpy as np

import uvteam.localizer as L
import uvteam.nodes.localizer as node_module
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import SimTeam

SPEED_BINS_M_S = ((0.0, 0.5), (0.5, 1.5), (1.5, 3.0), (3.0, 9.0))


def main(path: str, seed: int, t_s: float) -> None:
    team = SimTeam(load_scenario(path), seed, "pixels")
    step = node_module.localize_step
    rows = []

    def looked_at(state, obs, tracks, cfg):
        new_state, res = step(state, obs, tracks, cfg)
        if obs.px_per_m:
            pos = L.ugv_positions(tracks, obs.stamp_s, cfg)
            for u, j in res.blob_of_ugv.items():
                speed = (pos[u].speed_m_s if u in pos else None) or 0.0
                rows.append((speed, obs.blobs.area_px[j] / obs.px_per_m ** 2))
        return new_state, res

    node_module.localize_step = looked_at
    team.run(t_s)
    a = np.array(rows).reshape(-1, 2)
    for lo, hi in SPEED_BINS_M_S:
        m = a[(a[:, 0] >= lo) & (a[:, 0] < hi), 1]
        if len(m):
            q = np.percentile(m, [0, 1, 5, 50])
            print(f"{lo}-{hi} m/s: {len(m)} blobs, m2 min {q[0]:.2f}, 1 % {q[1]:.2f}, 5 % {q[2]:.2f}, "
                  f"median {q[3]:.2f}; under 4 m2: {(m < 4).sum()}")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]))
