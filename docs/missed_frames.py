"""Why a crowd was not reported: for every frame after the first second in which a true crowd got no
report, what the detector and the localizer had near it. A diagnostic for docs/results-worlds.md
(session 9); not part of the product. Use it on tuning seeds (1-3) or seeds outside a scenario's list.

    .venv/bin/python docs/missed_frames.py scenarios/real-alt60-lm6.toml 2

Runs one seed through the experiment (rendered frames, the deployed node classes) and prints, per
missed frame: the distance in pixels from the true crowd's projected centroid to the nearest blob, that
blob's label ("" for none, else the UGV it was taken for) and moving area (m2), how many crowd
estimates the localizer made in that frame, and how many crowds were reported.
"""

import json
import sys

import numpy as np

import uvteam.nodes.localizer as node_module
from uvteam.io.files import load_scenario
from radius_decomposition import record_camera_pose   # beside this file in docs/
from uvteam_sim.experiment import T0, SimTeam


def main(path: str, seed: int) -> dict:
    sc = load_scenario(path)
    team = SimTeam(sc, seed, "pixels")
    world, board = team.sim.world, team.scorer.board
    pose_now = record_camera_pose(world)
    seen: dict[float, tuple] = {}
    step = node_module.localize_step

    def looked_at(state, obs, tracks, cfg):
        new_state, res = step(state, obs, tracks, cfg)
        near = []
        for true_px in (np.nanmean(g, 0) for g in world.crowd_groups_px(pose_now[0])):
            if len(obs.blobs) and np.isfinite(true_px).all():
                d = np.hypot(*(obs.blobs.xy_px - true_px).T)
                k = int(np.argmin(d))
                area_m2 = float(obs.blobs.area_px[k] / obs.px_per_m ** 2)
                near.append((round(float(d[k]), 1), obs.blobs.ugv[k], round(area_m2, 1)))
            else:
                near.append(None)
        seen[round(obs.stamp_s - T0, 2)] = (near, len(res.crowds))
        return new_state, res

    node_module.localize_step = looked_at
    scored = team.scorer._add
    missed = []

    def add(truth, crowds):
        n0 = len(board.errors_m)
        scored(truth, crowds)
        t = round(truth.stamp_s - T0, 2)
        if t > 1.0 and truth.crowds and len(board.errors_m) - n0 < len(truth.crowds):
            near, n_estimates = seen.get(t, (None, None))
            missed.append({"t_s": t, "nearest_blob_px_label_area_m2": near, "crowd_estimates": n_estimates,
                           "reported": 0 if crowds is None else len(crowds.crowds)})

    team.scorer._add = add
    team.run()
    return {"scenario": sc.name, "seed": seed, "missed": len(missed), "frames": missed}


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1], int(sys.argv[2])), indent=1))
