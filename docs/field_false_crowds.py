"""Which of the field scenario's false crowds fall while its two crowds "mingle" by the scenarios'
rule (any two members of different crowds within 2 m: scored as one crowd). A diagnostic for
docs/results-pixels.md (session 8); not part of the product.

    .venv/bin/python docs/field_false_crowds.py ../shared/scenarios/field-alt100-lm6.toml 3

Runs one seed through the experiment (rendered frames, the deployed node classes) and prints the false
crowds, those in mingling frames, the mingling frames, and the mean error in and out of them.
"""

import json
import sys

import numpy as np

from uvteam.io.files import load_scenario
from uvteam_sim.experiment import SimTeam


def main(path: str, seed: int) -> dict:
    sc = load_scenario(path)
    if len(sc.crowds) != 2:
        raise SystemExit("a scenario with two crowds, please")
    team = SimTeam(sc, seed, "pixels")
    world, board = team.sim.world, team.scorer.board
    scored = team.scorer._add
    out = {"seed": seed, "false": 0, "false_mingling": 0, "frames_mingling": 0}
    err = {True: [], False: []}

    def add(truth, crowds):
        a, b = world.members(0), world.members(1)
        mingling = bool(np.sqrt(((a[:, None] - b[None]) ** 2).sum(-1)).min() < 2.0)
        false0, n0 = board.false_crowds, len(board.errors_m)
        scored(truth, crowds)
        new_false = board.false_crowds - false0
        out["false"] += new_false
        out["false_mingling"] += new_false if mingling else 0
        out["frames_mingling"] += int(mingling)
        err[mingling] += board.errors_m[n0:]

    team.scorer._add = add
    team.run()
    out["mean_m_mingling"] = float(np.mean(err[True])) if err[True] else None
    out["mean_m_other"] = float(np.mean(err[False])) if err[False] else None
    return out


if __name__ == "__main__":
    print(json.dumps(main(sys.argv[1], int(sys.argv[2]))))
