"""The crowds seen and the crowds held where their walk takes them, apart: an experiment's runs read
back from its output folder. A diagnostic for docs/results-worlds.md (session 11); not part of the
product.

    .venv/bin/python docs/seen_and_predicted.py out/worlds12

Per scenario: every scored frame (as `uvteam experiment`'s table counts them), the frames whose crowd
was predicted (``unseen_s`` > 0: not seen in that frame, `uvteam.crowds` step 6) with their error and
95 % coverage, and the frames seen: their mean and maximum error, coverage, and the recall after the
first second had the predicted frames not counted.
"""

import collections
import json
import sys
from pathlib import Path

import numpy as np

from uvteam.scoring import RECALL_AFTER_S


def main(folder: str) -> None:
    runs = collections.defaultdict(list)
    for path in sorted(Path(folder, "runs").glob("*.json")):
        run = json.loads(path.read_text())
        runs[run["scenario"]].append(run)
    print("| scenario | frames | mean m | max m | recall | in 95% radius | predicted | their mean m | their max m | "
          "their coverage | seen: mean m | seen: max m | seen: recall | seen: coverage |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, rs in sorted(runs.items()):
        err = np.concatenate([r["errors_m"] for r in rs])
        r95 = np.concatenate([r["radius95_m"] for r in rs])
        unseen = np.concatenate([r["unseen_s"] for r in rs])
        t = np.concatenate([r["times_s"] for r in rs])
        truth = sum(r["truth_frames"] for r in rs)
        found = sum(r["detected_frames"] for r in rs)
        pred, seen = unseen > 0, unseen == 0
        pred_counted = int((pred & (t >= RECALL_AFTER_S - 1e-9)).sum())
        held = (f"{err[pred].mean():.2f} | {err[pred].max():.2f} | {(err[pred] <= r95[pred]).mean():.3f}"
                if pred.any() else "- | - | -")
        print(f"| {name} | {len(err)} | {err.mean():.3f} | {err.max():.2f} | {found / truth:.3f} | "
              f"{(err <= r95).mean():.3f} | {int(pred.sum())} | {held} | {err[seen].mean():.3f} | {err[seen].max():.2f} | "
              f"{(found - pred_counted) / truth:.3f} | {(err[seen] <= r95[seen]).mean():.3f} |")


if __name__ == "__main__":
    main(sys.argv[1])
