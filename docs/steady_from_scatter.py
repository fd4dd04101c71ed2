"""How a crowd's steady offset follows the scatter of its own estimates (a diagnostic for
docs/results-pixels.md, session 14; not part of the product): how ``uvteam.crowds.GroupingConfig``'s
``steady_per_scatter`` and ``steady_min_m`` were chosen.

    .venv/bin/python docs/steady_from_scatter.py dump SCENARIO SEED OUT.json   # one seed, ~15 s
    .venv/bin/python docs/steady_from_scatter.py fit OUT.json ...               # coverage per scenario

``dump`` runs one seed through the experiment (rendered frames, the deployed node classes) with the
declared steady offset left as it is (``steady_per_scatter`` 0) and writes, per frame, each reported
crowd's position (in the world's frame), 95 % radius, whether it is held, its track's scatter about a
straight walk over ``scatter_s`` (:func:`uvteam.crowds.trail_scatter_m`), and every true crowd's centre.
``fit`` matches reports to the truth (Hungarian, gate 10 m, as the scoring), replaces the declared
steady part of each seen crowd's radius by ``k`` x scatter within [``lo``, declared] and prints each
scenario's coverage over the files given, for a grid of (k, lo), the closest to 0.915-0.975 first.
Its figures track the experiment's own: on tuning seeds 1-3 it predicted 0.932 / 0.937 / 0.964 / 0.930
for paper-fig7-alt200 / -alt50 / fig8-lm6 / fig9-color-lm6 at k 2.2, lo 0.3, the experiment gave
0.932 / 0.937 / 0.964 / 0.937.
"""

import functools
import json
import os
import sys

import numpy as np
from scipy.optimize import linear_sum_assignment

from uvteam.crowds import GroupingConfig, steady_sigma_m
from uvteam.detector_noise import PIXEL_SIGMA_M
from uvteam.localizer import R95_PER_SIGMA

GATE_M = 10.0


def dump(path: str, seed: int, out: str) -> None:
    import uvteam.nodes.localizer as node  # noqa: PLC0415
    from uvteam.crowds import trail_scatter_m  # noqa: PLC0415
    from uvteam.io.files import load_scenario  # noqa: PLC0415
    from uvteam_sim.experiment import SimTeam  # noqa: PLC0415

    sc = load_scenario(path)
    node.GroupingConfig = functools.partial(node.GroupingConfig, steady_per_scatter=0.0)
    team = SimTeam(sc, seed, "pixels")
    rows, report = [], node.report_crowds

    def on_report(state, estimates, stamp_s, cfg):
        state, reported = report(state, estimates, stamp_s, cfg)
        world, frame = team.sim.world, team.loc.frame
        crowds = []
        for r in reported:
            lat, lon = frame.ground_to_wgs84(r.estimate.east_m, r.estimate.north_m)
            e, n = world.frame.wgs84_to_ground(lat, lon)
            trail = tuple(p for p in r.track.trail if p[0] >= r.track.stamp_s - cfg.scatter_s)
            crowds.append([float(e), float(n), r.estimate.radius95_m, r.unseen_s,
                           trail_scatter_m(trail, cfg.scatter_min_points)])
        rows.append({"t": stamp_s, "now": team.clock(), "crowds": crowds,
                     "truth": [world.members(k).mean(0).tolist() for k in range(len(sc.crowds))]})
        return state, reported

    node.report_crowds = on_report
    team.run()
    with open(out, "w") as f:
        json.dump({"declared_sigma_m": PIXEL_SIGMA_M["crowd_blob"], "rows": rows}, f)


def load(files: list[str]) -> dict[str, tuple[np.ndarray, ...]]:
    per: dict[str, list[list]] = {}
    for name in files:
        d = json.load(open(name))
        declared = d["declared_sigma_m"]
        rows = d["rows"]
        now = np.array([r["now"] for r in rows])
        acc = per.setdefault(os.path.basename(name).rsplit("_", 1)[0], [])
        for r in rows:
            i = int(np.argmin(abs(now - r["t"])))      # the truth at the frame's capture time
            if not r["crowds"] or not rows[i]["truth"] or abs(now[i] - r["t"]) > 0.02:
                continue
            p, t = np.array([c[:2] for c in r["crowds"]]), np.array(rows[i]["truth"])
            dist = np.linalg.norm(p[:, None] - t[None], axis=2)
            for a, b in zip(*linear_sum_assignment(dist)):
                if dist[a, b] <= GATE_M:
                    c = r["crowds"][a]
                    acc.append([dist[a, b], c[2], c[4], c[3], declared])
    return {k: np.array(v).T for k, v in per.items()}


def coverage(data, k: float, lo: float) -> dict[str, float]:
    """Each scenario's coverage with the seen crowds' steady part narrowed as uvteam.crowds narrows it
    (:func:`uvteam.crowds.steady_sigma_m`; a track too short to fit keeps the declared part)."""
    cfg = GroupingConfig(steady_per_scatter=k, steady_min_m=lo)
    out = {}
    for name, (err, r95, scatter, unseen, declared) in sorted(data.items()):
        own = np.array([steady_sigma_m(s, d, cfg) if s > 0 else d for s, d in zip(scatter, declared)])
        r = np.sqrt(np.maximum(r95 ** 2 - (R95_PER_SIGMA * declared) ** 2 + (R95_PER_SIGMA * own) ** 2, 0.0))
        r = np.where(unseen > 0, r95, r)                # a held crowd's radius is left as it is here
        out[name] = float(np.mean(err <= r))
    return out


def fit(files: list[str]) -> None:
    data = load(files)
    print("declared:", "  ".join(f"{n} {c:.3f}" for n, c in coverage(data, 0.0, 0.0).items()))
    grid = []
    for k in np.arange(1.4, 3.01, 0.2):
        for lo in (0.2, 0.25, 0.3, 0.35, 0.4):
            c = coverage(data, k, lo)
            v = np.array(list(c.values()))
            grid.append((float(np.sum(np.maximum(0, 0.915 - v) + np.maximum(0, v - 0.975))), k, lo, c))
    for miss, k, lo, c in sorted(grid, key=lambda g: g[0])[:8]:
        print(f"k {k:.1f} lo {lo:.2f} off-band {miss:.3f}:", "  ".join(f"{n} {v:.3f}" for n, v in c.items()))


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == "dump":
        dump(sys.argv[2], int(sys.argv[3]), sys.argv[4])
    elif len(sys.argv) >= 3 and sys.argv[1] == "fit":
        fit(sys.argv[2:])
    else:
        sys.exit(__doc__)
