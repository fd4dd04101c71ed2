# FROZEN: uvteam/assignment.py as it was at commit 4d30179 (before the localizer was made faster), the reference
# that uvteam_ground.bench_localize measures the product against and checks it equals. Do not edit.
"""Landmark <-> motion-blob assignment (the paper's problem (2)).

Each color-detected landmark (a UGV's roof label) gets at most one motion blob whose centre lies
within ``gate_px`` (the paper's epsilon) of it. Among all gated matchings the optimal solver takes
the ones with the most pairs and, among those, the least total distance (with "at most one" alone the
empty matching would be optimal, which is not what the paper means). Blobs left unassigned are the
crowd candidates; blobs inside the gate of any landmark, even one that lost the matching to a closer
blob, are never crowds (a UGV must never come out as a crowd).

Two solvers: :func:`assign_optimal` (Hungarian, scipy.optimize.linear_sum_assignment, with gating by a
cost larger than any feasible matching) and :func:`assign_greedy`, the paper's heuristic:

  1. compute the distance d_ij from every landmark i to every blob j;
  2. mark every pair with d_ij > epsilon infeasible;
  3. if no feasible pair remains, stop;
  4. pick the feasible pair (i, j) with the smallest d_ij (ties: lowest i, then lowest j);
  5. assign blob j to landmark i;
  6. remove landmark i (its row) from further consideration;
  7. remove blob j (its column) from further consideration;
  8. go to 3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

__all__ = ["Assignment", "assign_optimal", "assign_greedy", "distance_matrix"]


@dataclass(frozen=True, slots=True)
class Assignment:
    """pairs: (k, 2) int array of (landmark index, blob index); the rest derived from it."""

    pairs: np.ndarray
    n_landmarks: int
    n_blobs: int
    gated_blobs: np.ndarray  # (n_blobs,) bool: inside some landmark's gate (never a crowd)

    @property
    def blob_of_landmark(self) -> dict[int, int]:
        return {int(i): int(j) for i, j in self.pairs}

    @property
    def target_blobs(self) -> np.ndarray:
        """Indices of blobs that are neither assigned nor within any landmark's gate."""
        keep = ~self.gated_blobs
        keep[self.pairs[:, 1]] = False
        return np.flatnonzero(keep)

    def total_distance(self, d: np.ndarray) -> float:
        return float(d[self.pairs[:, 0], self.pairs[:, 1]].sum()) if len(self.pairs) else 0.0


def distance_matrix(landmarks_xy_px, blobs_xy_px) -> np.ndarray:
    a = np.asarray(landmarks_xy_px, float).reshape(-1, 2)
    b = np.asarray(blobs_xy_px, float).reshape(-1, 2)
    return np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1))


def _result(pairs, d: np.ndarray, gate_px: float) -> Assignment:
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    with np.errstate(invalid="ignore"):
        gated = (d <= gate_px).any(axis=0) if d.size else np.zeros(d.shape[1], bool)
    return Assignment(pairs, d.shape[0], d.shape[1], gated)


def assign_optimal(landmarks_xy_px, blobs_xy_px, gate_px: float) -> Assignment:
    """Most pairs within the gate, then least total distance (exact, Hungarian)."""
    if not gate_px > 0:
        raise ValueError(f"gate_px must be > 0, got {gate_px}")
    d = distance_matrix(landmarks_xy_px, blobs_xy_px)
    if d.size == 0:
        return _result([], d, gate_px)
    feasible = np.isfinite(d) & (d <= gate_px)
    big = gate_px * (min(d.shape) + 1)  # larger than any feasible matching's total
    cost = np.where(feasible, d, big)
    rows, cols = linear_sum_assignment(cost)
    ok = feasible[rows, cols]
    return _result(np.stack([rows[ok], cols[ok]], axis=1), d, gate_px)


def assign_greedy(landmarks_xy_px, blobs_xy_px, gate_px: float) -> Assignment:
    """The paper's 8-step greedy heuristic (module docstring)."""
    if not gate_px > 0:
        raise ValueError(f"gate_px must be > 0, got {gate_px}")
    d = distance_matrix(landmarks_xy_px, blobs_xy_px)                  # step 1
    work = np.where(np.isfinite(d) & (d <= gate_px), d, np.inf)       # step 2
    pairs = []
    while np.isfinite(work).any():                                     # step 3 / 8
        i, j = np.unravel_index(np.argmin(work), work.shape)          # step 4 (row-major: ties low i, j)
        pairs.append((i, j))                                           # step 5
        work[i, :] = np.inf                                            # step 6
        work[:, j] = np.inf                                            # step 7
    return _result(pairs, d, gate_px)
