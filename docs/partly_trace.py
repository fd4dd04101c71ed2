"""Per frame between two times: what step 7 of :mod:`uvteam.crowds` (a crowd partly seen) made of the first
crowd: its moving pixels against its usual, how far where it was seen, where its walk has it and where it
was reported lie from its true centre, its radius, and the walk's velocity against the crowd's. A diagnostic
for docs/results-worlds.md (session 35); not part of the product. Use it on tuning seeds or to trace a
figure already reported.

    .venv/bin/python docs/partly_trace.py scenarios/real-alt60-lm6.toml 32 2.0 9.0
"""

import sys

import numpy as np

import uvteam.crowds as crowds
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import T0, SimTeam


def main(path: str, seed: int, t0_s: float, t1_s: float) -> None:
    team = SimTeam(load_scenario(path), seed, "pixels")
    world = team.sim.world
    partly_seen = crowds._partly_seen

    def looked_at(r, ls, stamp_s, cfg):
        out = partly_seen(r, ls, stamp_s, cfg)
        t = stamp_s - T0
        if not t0_s <= t <= t1_s:
            return out
        lat, lon = world.frame.ground_to_wgs84(*world.crowd_centroids()[0])
        truth = np.array(team.loc.frame.wgs84_to_ground(lat, lon), float)    # in the localizer's own frame
        c, o = r.estimate, out.estimate
        usual = ls.usual_px() if ls is not None and ls.areas else float("nan")
        walk = ls.walk_at(stamp_s, cfg)[0] if ls is not None else np.full(2, np.nan)
        v = "-" if ls is None else f"({ls.v_en_m_s[0]:.2f}, {ls.v_en_m_s[1]:.2f})"
        print(f"t {t:5.1f} s  crowd {r.crowd_id}  px {c.area_px:6.0f} usual {usual:6.0f}  seen {_off(c, truth):5.2f} m  "
              f"walk {np.hypot(*(walk - truth)):5.2f} m  reported {_off(o, truth):5.2f} m  r95 {o.radius95_m:4.2f} m  "
              f"partly {'yes' if out.partly_seen else 'no '}  walk v {v}  true v ({world.crowd_v[0][0]:.2f}, "
              f"{world.crowd_v[0][1]:.2f}) m/s", flush=True)
        return out

    def _off(c, truth) -> float:
        return float(np.hypot(c.east_m - truth[0], c.north_m - truth[1]))

    crowds._partly_seen = looked_at
    team.run(t1_s + 0.2)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]))
