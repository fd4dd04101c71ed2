"""Why two crowds were reported as one: per frame with two crowds scored and one reported, whether the
localizer had one estimate for both (the detector's blob held both: case A) or several, some metres apart,
that the grouping joined (case B). A diagnostic for docs/results-worlds.md (session 37); not part of the
product. Use it on tuning seeds or to trace a figure already reported.

    .venv/bin/python docs/two_crowd_frames.py scenarios/real-alt60-lm6-two.toml 11 12 13

Runs each seed through the experiment (rendered frames, the deployed node classes) and prints, per seed, the
count of each case and the spans of frames in it, with the truth crowds' distance and the estimates' spread.
Estimates below a fifth of the largest one's moving pixels are left out (stray pieces).
"""

import sys

import numpy as np

import uvteam.nodes.localizer as node_module
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import T0, SimTeam


def frames(path: str, seed: int) -> list[tuple[float, str, float, float]]:
    """(time s, case, truth distance m, largest distance between estimates m) per frame of interest."""
    team = SimTeam(load_scenario(path), seed, "pixels")
    estimates: dict[float, np.ndarray] = {}
    step = node_module.localize_step

    def looked_at(state, obs, tracks, cfg):
        new_state, res = step(state, obs, tracks, cfg)
        estimates[round(obs.stamp_s - T0, 2)] = np.array([[c.east_m, c.north_m, c.area_px] for c in res.crowds],
                                                         float).reshape(-1, 3)
        return new_state, res

    rows = []
    scored = team.scorer._add

    def add(truth, crowds):
        t = round(truth.stamp_s - T0, 2)
        if t >= 1.0 and len(truth.crowds) == 2 and crowds is not None and len(crowds.crowds) == 1:
            tru = team.scorer._en([x.lat_deg for x in truth.crowds], [x.lon_deg for x in truth.crowds])
            e = estimates.get(t, np.empty((0, 3)))
            big = e[e[:, 2] >= 0.2 * e[:, 2].max()] if len(e) else e
            spread = max((float(np.hypot(*(a[:2] - b[:2]))) for a in big for b in big), default=0.0)
            rows.append((t, "A: one estimate" if len(big) <= 1 else "B: estimates joined",
                         float(np.hypot(*(tru[0] - tru[1]))), spread))
        scored(truth, crowds)

    node_module.localize_step = looked_at
    team.scorer._add = add
    try:
        team.run(team.sc.run.duration_s)
    finally:
        node_module.localize_step = step
    return rows


def main(path: str, seeds: list[int]) -> None:
    for seed in seeds:
        rows = frames(path, seed)
        counts = {k: sum(r[1] == k for r in rows) for k in sorted({r[1] for r in rows})}
        print(f"seed {seed}: {counts}")
        span = None
        for t, case, d_truth, spread in rows + [(float("inf"), "", 0.0, 0.0)]:
            if span and case == span[1] and t - span[2] < 0.15:
                span[2:] = [t, span[3] + [d_truth], span[4] + [spread]]
                continue
            if span:
                print(f"   {span[0]:5.1f}-{span[2]:5.1f} s  {span[1]:20s} truth {min(span[3]):.1f}-{max(span[3]):.1f} m"
                      f" apart, estimates {min(span[4]):.1f}-{max(span[4]):.1f} m")
            span = [t, case, t, [d_truth], [spread]]


if __name__ == "__main__":
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    main(sys.argv[1], [int(s) for s in sys.argv[2:]])
