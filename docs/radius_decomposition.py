"""Where a crowd's error comes from, against the 95 % radius parts that should hold it (a diagnostic
for docs/results-pixels.md, session 8; not part of the product).

    .venv/bin/python docs/radius_decomposition.py ../shared/scenarios/field-alt100-lm6.toml 2

Runs one seed of a scenario through the experiment (rendered frames, the deployed node classes) and,
for every crowd estimate the localizer makes (before grouping), splits its error against the true
crowd centroid with the simulator's true camera pose:

- transform part: where the frame's fit puts the true crowd's pixel (its members' projected mean),
  against the truth; held by the radius of the landmarks' propagated noise alone (``rT``);
- detector part: the estimate against that point (the blob centre's offset on the ground); held by
  the crowd-blob term the detector declares (``rD``).

Prints per fit quality the share of each part inside its radius, its RMS per axis, and the detector
part split into what stays over 1 s (steady) and what changes from frame to frame.
"""

import json
import sys

import numpy as np

import uvteam.nodes.localizer as node_module
from uvteam.homography import radius95_m
from uvteam.io.files import load_scenario
from uvteam.localizer import R95_PER_SIGMA, FitQuality
from uvteam_sim.experiment import T0, SimTeam


def record_camera_pose(world) -> list:
    """Keeps the simulator's true camera pose of the frame last rendered in the returned one-item list."""
    pose_now = [None]
    camera_pose = world.camera_pose

    def recorded_pose():
        pose_now[0] = camera_pose()
        return pose_now[0]

    world.camera_pose = recorded_pose
    return pose_now


def main(path: str, seed: int) -> dict:
    sc = load_scenario(path)
    team = SimTeam(sc, seed, "pixels")
    world = team.sim.world
    pose_now = record_camera_pose(world)
    rows, vec = [], []
    step = node_module.localize_step

    def decomposed(state, obs, tracks, cfg):
        new_state, res = step(state, obs, tracks, cfg)
        t = obs.stamp_s - T0
        true_px = [np.nanmean(g, 0) for g in world.crowd_groups_px(pose_now[0])]
        truth = [c for c, _ in world.truth_crowds()]
        if truth:   # the truth in the localizer's frame
            lat, lon = world.frame.ground_to_wgs84(np.array([c[0] for c in truth]), np.array([c[1] for c in truth]))
            e, n = team.loc.frame.wgs84_to_ground(lat, lon)
            truth = [np.array([a, b]) for a, b in zip(e, n)]
        s_lm, s_tg = cfg.sigmas_px(obs)
        for c in res.crowds:
            en = np.array([c.east_m, c.north_m])
            d = [float(np.hypot(*(en - x))) for x in truth]
            if not d or min(d) > 10.0 or c.quality == FitQuality.POSE or new_state.last_fit is None:
                continue
            k = int(np.argmin(d))
            sig_m = new_state.last_fit_sigma_m if new_state.last_fit_sigma_m is not None else 0.0
            en_t, cov_t = new_state.last_fit.map_points_with_cov(true_px[k][None], 0.0, s_lm, sig_m)
            e_t, e_d = en_t[0] - truth[k], en - en_t[0]
            rows.append((c.quality.value, d[k], c.radius95_m, float(np.hypot(*e_t)), float(radius95_m(cov_t)[0]),
                         float(np.hypot(*e_d)), R95_PER_SIGMA * s_tg / obs.px_per_m))
            vec.append((t, k, *e_d))
        return new_state, res

    node_module.localize_step = decomposed
    team.run()
    out = {"scenario": sc.name, "seed": seed}
    qualities = np.array([r[0] for r in rows])
    a = np.array([r[1:] for r in rows], float).reshape(-1, 6)
    for q in sorted(set(qualities)):
        b = a[qualities == q]
        out[q] = {"n": len(b), "in_radius": float(np.mean(b[:, 0] <= b[:, 1])),
                  "transform_in_rT": float(np.mean(b[:, 2] <= b[:, 3])), "transform_rms_m": float(np.sqrt((b[:, 2] ** 2).mean() / 2)),
                  "detector_in_rD": float(np.mean(b[:, 4] <= b[:, 5])), "detector_rms_m": float(np.sqrt((b[:, 4] ** 2).mean() / 2))}
    v = np.array(vec, float).reshape(-1, 4)
    frame, steady = [], []
    for k in set(v[:, 1].astype(int)):
        w = v[v[:, 1] == k]
        for i in range(len(w)):
            mean_1s = w[np.abs(w[:, 0] - w[i, 0]) <= 1.0][:, 2:].mean(0)
            steady.append(mean_1s)
            frame.append(w[i, 2:] - mean_1s)
    out["detector_rms_per_axis_m"] = {"steady_1s": float(np.sqrt((np.array(steady) ** 2).mean())),
                                      "per_frame": float(np.sqrt((np.array(frame) ** 2).mean()))}
    return out


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1], int(sys.argv[2])), indent=1))
