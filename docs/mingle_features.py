"""Does anything the grouping knows of two crowds tell whether the scenarios count them as one (walkers of the two
within 2 m)? A diagnostic for docs/results-worlds.md (session 41); not part of the product. Use it on tuning seeds.

    .venv/bin/python docs/grouping_replay.py record REC ../shared/scenarios/field-alt100-lm6.toml 1 2 3
    .venv/bin/python docs/grouping_replay.py record REC scenarios/real-alt60-lm6-two.toml 1 2 3 11 12 13 14 15 16
    .venv/bin/python docs/mingle_features.py REC

Replays every recording in REC through :func:`uvteam.crowds.report_crowds` (the code on the path, as
`docs/grouping_replay.py replay` does) and, per world, counts the frames after the first second with two crowds
reported, split by whether the scoring has one crowd there (the team's second report is a false crowd) or two,
against the distance between the two reports' centres and the gap between their footprints (boxes east/north,
0 where they overlap); then the frames with one crowd reported whose blob holds another (step 8), against how far
the held crowd's walk has it from the blob's centre, split by whether the scoring has one crowd or two.
"""

import glob
import os
import pickle
import sys

import numpy as np

from grouping_replay import recorded_events
from uvteam.crowds import GroupingConfig, GroupingState, _box_gaps_m, _boxes_en, report_crowds

CENTRE_BINS_M = (0, 7, 8, 9, 10, 11, 12, 15, np.inf)
GAP_BINS_M = (-1, 0, 0.5, 1, 1.5, 2, 3, 5, np.inf)
HELD_BINS_M = (0, 3, 4, 5, 6, 7, 8, np.inf)


def frames(path: str):
    """Per frame after the first second: (scored crowds, reported crowds, the blob's held crowds' places)."""
    with open(path, "rb") as f:
        rec = pickle.load(f)
    cfg = GroupingConfig(confirm_hits=rec["confirm_hits"])
    state, reported, scored, first = GroupingState(), [], {}, None
    for kind, a, b, shift in recorded_events(rec):
        if kind == "frame":
            state, reported = report_crowds(state, a, b, cfg, shift)
            held = [ls.walk_at(b, cfg)[0] for v in state.inside.values() for ls in v]
        elif kind == "truth":
            scored[round(b.stamp_s, 3)] = len(b.crowds)
            first = b.stamp_s if first is None else first
        elif b.stamp_s - first >= 1.0 and round(b.stamp_s, 3) in scored:
            yield scored[round(b.stamp_s, 3)], list(reported), held


def table(name: str, values: list[tuple[float, int]], bins) -> None:
    v = np.array(values, float).reshape(-1, 2)
    cells = []
    for lo, hi in zip(bins[:-1], bins[1:]):
        m = (v[:, 0] > lo) & (v[:, 0] <= hi)
        cells.append(f"{lo:g}-{hi:g}: {int((m & (v[:, 1] == 1)).sum())}/{int((m & (v[:, 1] == 2)).sum())}")
    print(f"  {name} (scored one / scored two): " + ", ".join(cells))


def main(rec_dir: str) -> None:
    worlds: dict[str, list[str]] = {}
    for p in sorted(glob.glob(os.path.join(rec_dir, "*.pkl"))):
        worlds.setdefault(os.path.basename(p).rsplit("__seed", 1)[0], []).append(p)
    for world, paths in sorted(worlds.items()):
        centre, gap, held_off = [], [], []
        for p in paths:
            for n_scored, reported, held in frames(p):
                en = np.array([[r.estimate.east_m, r.estimate.north_m] for r in reported]).reshape(-1, 2)
                if len(reported) == 2 and n_scored in (1, 2):
                    centre.append((float(np.hypot(*(en[0] - en[1]))), n_scored))
                    g = float(_box_gaps_m(_boxes_en([r.estimate for r in reported]))[0, 1])
                    gap.append((g if g > 0 else -0.5, n_scored))
                elif len(reported) == 1 and held and n_scored in (1, 2):
                    held_off.append((min(float(np.hypot(*(np.asarray(h) - en[0]))) for h in held), n_scored))
        print(f"{world} ({len(paths)} recordings): {len(centre)} frames with two crowds reported, "
              f"{sum(n == 1 for _, n in centre)} of them scored as one")
        table("centres apart, m", centre, CENTRE_BINS_M)
        table("footprints apart, m (-1-0: overlapping)", gap, GAP_BINS_M)
        print(f"  {len(held_off)} frames with one crowd reported, its blob holding another")
        table("held crowd's walk from the blob's centre, m", held_off, HELD_BINS_M)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    main(sys.argv[1])
