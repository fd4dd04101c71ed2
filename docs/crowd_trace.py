"""Per frame, between two times: the localizer's estimates (its own local frame; area in moving pixels,
95 % radius) and the crowds the team reports against the truth (the scoring's frame: east/north m, error,
radius, seconds unseen, velocity), and where the camera's pose alone puts each estimate's blob (session 55). A
diagnostic for docs/results-worlds.md (session 23); not part of the product. Use it on tuning seeds or to trace
a figure already reported.

    .venv/bin/python docs/crowd_trace.py scenarios/real-alt120-lm6.toml 9 1.8 5.8
"""

import sys

import numpy as np

import uvteam.nodes.localizer as node_module
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import T0, SimTeam


def main(path: str, seed: int, t0_s: float, t1_s: float) -> None:
    team = SimTeam(load_scenario(path), seed, "pixels")
    estimates: dict[float, list] = {}
    step = node_module.localize_step

    def looked_at(state, obs, tracks, cfg):
        new_state, res = step(state, obs, tracks, cfg)
        rows = []
        for c in res.crowds:     # and where the camera's pose alone (no bias learnt) puts the same blob
            at, sigma = (np.nan, np.nan), np.nan
            if obs.pose is not None:
                at = obs.pose.px_to_ground(obs.blobs.xy_px[c.blob_index][None])[0]
                sigma = float(obs.pose.sigma_m(at[None])[0])
            rows.append((c.east_m, c.north_m, c.area_px, c.radius95_m, c.quality.value, *at, sigma))
        estimates[round(obs.stamp_s - T0, 2)] = rows
        return new_state, res

    node_module.localize_step = looked_at
    scored = team.scorer._add

    def add(truth, crowds):
        t = round(truth.stamp_s - T0, 2)
        if t0_s <= t <= t1_s:
            tru = team.scorer._en([x.lat_deg for x in truth.crowds], [x.lon_deg for x in truth.crowds])
            cs = crowds.crowds if crowds is not None else ()
            rep = team.scorer._en([x.lat_deg for x in cs], [x.lon_deg for x in cs])
            print(f"t {t:5.2f} s  truth {np.round(tru, 2).tolist()}")
            for x, en in zip(cs, rep):
                err = float(np.hypot(*(tru - en).T).min()) if len(tru) else float("nan")
                print(f"   reported {x.crowd_id}: {np.round(en, 2).tolist()} error {err:.2f} m, r95 {x.radius95_m:.2f} m, "
                      f"unseen {x.unseen_s:.1f} s, v ({x.v_east_m_s:.2f}, {x.v_north_m_s:.2f}) m/s")
            for e, n, area, r95, q, pe, pn, ps in estimates.get(t, []):
                print(f"   estimate ({e:.2f}, {n:.2f}) m, {area:.0f} px, r95 {r95:.2f} m, {q}; "
                      f"the pose alone ({pe:.2f}, {pn:.2f}) m, 1-sigma {ps:.2f} m")
        scored(truth, crowds)

    team.scorer._add = add
    team.run(t1_s + 0.2)


if __name__ == "__main__":
    if len(sys.argv) != 5:
        raise SystemExit(__doc__)
    main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]))
