"""Two `uvteam experiment` outputs compared run by run: what a change moved, seed by seed and per scenario,
beside how far the closed loop moves for a change that should move nothing (docs/results-worlds.md, session
39: a seed's mean by up to about 0.04 m in a one-crowd world, 0.1 m and 60 false crowds in a two-crowd seed).
A diagnostic for docs/; not part of the product.

    .venv/bin/python docs/compare_runs.py out/before out/after

Reads ``<out>/runs/*.json`` of both and pairs the runs of the same scenario and seed; prints each pair's mean
error, false crowds, matched crowd-frames and 95 % coverage, new minus old, then per scenario the same over its
paired seeds and the median and largest change of a seed's mean.
"""

import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np


def runs(out: Path) -> dict[tuple[str, int], dict]:
    """Each run of an experiment's output by (scenario, seed): mean error, false crowds, frames, coverage."""
    got = {}
    for f in sorted((out / "runs").glob("*.json")):
        r = json.loads(f.read_text())
        e = np.asarray(r["errors_m"], float)
        got[(r["scenario"], int(r["seed"]))] = {
            "errors": e, "inside": e <= np.asarray(r["radius95_m"], float), "false": int(r["false_crowds"]),
            "matched": int(r["detected_frames"]), "truth": int(r["truth_frames"]), "ugv": int(r["ugv_as_crowd"])}
    return got


def main(old_dir: str, new_dir: str) -> None:
    old, new = runs(Path(old_dir)), runs(Path(new_dir))
    both = sorted(set(old) & set(new))
    if not both:
        sys.exit(f"no run (scenario and seed) in both {old_dir} and {new_dir}")
    by_scenario = defaultdict(list)
    print(f"{'scenario':<32} {'seed':>4} {'mean m':>15} {'d mean':>7} {'false':>11} {'matched':>13} {'d cover':>7}")
    for k in both:
        a, b = old[k], new[k]
        by_scenario[k[0]].append(k)
        print(f"{k[0]:<32} {k[1]:>4} {a['errors'].mean():>6.3f} -> {b['errors'].mean():.3f} "
              f"{b['errors'].mean() - a['errors'].mean():>+7.3f} {a['false']:>4} -> {b['false']:<4} "
              f"{a['matched']:>5} -> {b['matched']:<5} {b['inside'].mean() - a['inside'].mean():>+7.3f}")
    print()
    for sc, keys in by_scenario.items():
        def total(d: dict, f) -> float:
            return f([d[k] for k in keys])
        ea = total(old, lambda rs: np.concatenate([r["errors"] for r in rs]))
        eb = total(new, lambda rs: np.concatenate([r["errors"] for r in rs]))
        recall = [total(d, lambda rs: sum(r["matched"] for r in rs) / max(1, sum(r["truth"] for r in rs))) for d in (old, new)]
        false = [total(d, lambda rs: sum(r["false"] for r in rs)) for d in (old, new)]
        ugv = [total(d, lambda rs: sum(r["ugv"] for r in rs)) for d in (old, new)]
        d_seed = np.abs([new[k]["errors"].mean() - old[k]["errors"].mean() for k in keys])
        print(f"{sc}: {len(keys)} seeds, mean {ea.mean():.3f} -> {eb.mean():.3f} m, recall {recall[0]:.3f} -> "
              f"{recall[1]:.3f}, false crowds {false[0]} -> {false[1]}, UGV as crowd {ugv[0]} -> {ugv[1]}; "
              f"a seed's mean moved by a median {np.median(d_seed):.3f} m, at most {d_seed.max():.3f} m")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
