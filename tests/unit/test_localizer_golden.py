"""The localizer step gives the results it gave when these inputs were recorded (to 1e-9), so that a
faster step is the same step. Inputs: every 4th frame of a field-alt100-lm6 run (sensor model, 8 s,
seed 2) and a paper-fig8-lm4 run (rendered pixels, 4 s, seed 2), recorded from the experiment's
localizer node (tests/data/localizer_steps.pkl.gz)."""

import dataclasses
import gzip
import pickle
from pathlib import Path

import numpy as np
import pytest

from uvteam.localizer import LocalizerConfig, localize_step

DATA = Path(__file__).resolve().parents[1] / "data" / "localizer_steps.pkl.gz"


def _steps():
    with gzip.open(DATA, "rb") as f:
        return pickle.load(f)


def _upgraded(x):
    """A state or observation recorded before a field was added: the new fields at their defaults (what
    the recorded step had: the landmarks' noise as declared, the crowds' noise all per frame)."""
    missing = dataclasses.MISSING
    return type(x)(**{f.name: getattr(x, f.name) for f in dataclasses.fields(x) if getattr(x, f.name, missing) is not missing})


@pytest.mark.parametrize("k", range(31))
def test_step_gives_the_recorded_result(k):
    state, obs, tracks, cfg, (want_state, want) = _steps()[k]
    got_state, got = localize_step(_upgraded(state), _upgraded(obs), tracks, LocalizerConfig(**cfg))   # new fields: their defaults
    assert got.quality == want.quality and got.landmarks_used == want.landmarks_used
    assert got.outlier_landmarks == want.outlier_landmarks and got.blob_of_ugv == want.blob_of_ugv
    assert len(got.crowds) == len(want.crowds)
    for a, b in zip(got.crowds, want.crowds):
        assert a.blob_index == b.blob_index and a.quality == b.quality
        np.testing.assert_allclose([a.east_m, a.north_m, a.radius95_m], [b.east_m, b.north_m, b.radius95_m], rtol=0, atol=1e-9)
        np.testing.assert_allclose(a.footprint_en_m, b.footprint_en_m, rtol=0, atol=1e-9)
    if want_state.last_fit is not None:
        np.testing.assert_allclose(got_state.last_fit.H_ground_from_px, want_state.last_fit.H_ground_from_px, rtol=1e-12, atol=1e-12)
    assert got_state.interval_start_s == want_state.interval_start_s
    assert got_state.blob_px_of_ugv == want_state.blob_px_of_ugv
