import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uvteam.assignment import assign_greedy, assign_optimal, distance_matrix


def brute_force(d, gate):
    """Most pairs within the gate, then least total distance, by enumeration."""
    L, B = d.shape
    best = (0, 0.0, ())
    for k in range(min(L, B), 0, -1):
        for rows in itertools.combinations(range(L), k):
            for cols in itertools.permutations(range(B), k):
                if all(d[r, c] <= gate for r, c in zip(rows, cols)):
                    tot = sum(d[r, c] for r, c in zip(rows, cols))
                    if k > best[0] or (k == best[0] and tot < best[1] - 1e-12):
                        best = (k, tot, tuple(zip(rows, cols)))
        if best[0] == k:
            break
    return best


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 4), st.integers(0, 5), st.integers(0, 100_000))
def test_optimal_equals_brute_force(L, B, seed):
    rng = np.random.default_rng(seed)
    lm = rng.uniform(0, 100, (L, 2))
    bl = rng.uniform(0, 100, (B, 2))
    gate = 30.0
    d = distance_matrix(lm, bl)
    a = assign_optimal(lm, bl, gate)
    k, tot, _ = brute_force(d, gate) if L and B else (0, 0.0, ())
    assert len(a.pairs) == k
    assert a.total_distance(d) == pytest.approx(tot, abs=1e-9)
    assert all(d[i, j] <= gate for i, j in a.pairs)


@pytest.mark.parametrize(
    "landmarks, blobs, gate, greedy_pairs, optimal_pairs",
    [
        # worked: d = [[4, 5], [6, 15]], gate 6. Step 4 picks (0,0) (d=4); steps 6-7 remove landmark 0
        # and blob 0; landmark 1's only other blob is 15 px away, outside the gate: unmatched.
        # The optimum matches both: (0,1) + (1,0) = 5 + 6.
        ([[0, 0], [10, 0]], [[4, 0], [-5, 0]], 6.0, [(0, 0)], [(0, 1), (1, 0)]),
        # worked: d = [[1, 8], [9, 2]]: greedy takes (0,0) then (1,1), which is also optimal
        ([[0, 0], [10, 0]], [[1, 0], [8, 0]], 5.0, [(0, 0), (1, 1)], [(0, 0), (1, 1)]),
        # worked: one landmark, blobs at 3 and 4 px: both take the nearest
        ([[0, 0]], [[3, 0], [0, 4]], 5.0, [(0, 0)], [(0, 0)]),
        # worked: all blobs outside the gate: nothing is assigned
        ([[0, 0], [50, 50]], [[20, 0]], 5.0, [], []),
        # worked: tie at equal distance: greedy takes the lowest landmark, then lowest blob
        ([[0, 0], [4, 0]], [[2, 0]], 5.0, [(0, 0)], None),
        # empty inputs
        (np.empty((0, 2)), [[1, 1]], 5.0, [], []),
        ([[1, 1]], np.empty((0, 2)), 5.0, [], []),
    ],
)
def test_greedy_steps_hand_worked(landmarks, blobs, gate, greedy_pairs, optimal_pairs):
    g = assign_greedy(landmarks, blobs, gate)
    assert [tuple(p) for p in g.pairs.tolist()] == greedy_pairs
    if optimal_pairs is not None:
        o = assign_optimal(landmarks, blobs, gate)
        assert sorted(tuple(p) for p in o.pairs.tolist()) == optimal_pairs


def test_gated_blob_never_a_target():
    # two blobs near one UGV (its body split in two): the loser of the matching is still no crowd
    a = assign_optimal([[100, 100]], [[102, 100], [96, 101], [400, 300]], 10.0)
    assert a.blob_of_landmark == {0: 0}
    assert a.target_blobs.tolist() == [2]


def test_nan_landmark_is_ignored():
    a = assign_optimal([[np.nan, 0], [0, 0]], [[1, 0]], 5.0)
    assert a.blob_of_landmark == {1: 0}


def test_bad_gate():
    with pytest.raises(ValueError):
        assign_optimal([[0, 0]], [[1, 1]], 0.0)
