"""Nothing computed is lost: `uvteam experiment` writes each run as it finishes, resumes, and says so
(exit 2) when its output cannot be written, before running anything or when the disk fills mid-way.
The runs are real (the desert scenario of scenarios/, procedural ground, shortened to 2 s)."""

import errno
import json
import platform
import re

import numpy as np
import pytest

from conftest import OWN_SCENARIOS
from uvteam_sim import experiment


@pytest.fixture
def short(tmp_path):
    text = (OWN_SCENARIOS / "desert-alt60-lm6-distractors.toml").read_text()
    text = re.sub(r"(?m)^duration_s = .*$", "duration_s = 2.0", text)
    text = re.sub(r'(?m)^name = .*$', 'name = "short"', text)
    path = tmp_path / "short.toml"
    path.write_text(text)
    return path


@pytest.fixture
def counted(monkeypatch):
    """Count the runs actually computed (the real ones, through the real job function)."""
    seeds: list[int] = []
    real = experiment._run_job

    def job(j):
        seeds.append(j[1])
        return real(j)

    monkeypatch.setattr(experiment, "_run_job", job)
    return seeds


def _args(short, out, *more):
    return [str(short), "--seed", "1", "--seed", "2", "--seed", "3", "--jobs", "1", "--out", str(out), *more]


def test_an_unwritable_out_is_an_error_before_any_run(short, tmp_path, counted, capsys):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    assert experiment.main(_args(short, blocker / "out")) == 2
    assert counted == [] and "cannot write results there" in capsys.readouterr().err


def test_a_disk_that_fills_mid_way_keeps_the_runs_written_and_resume_finishes(short, tmp_path, counted,
                                                                              monkeypatch, capsys):
    out = tmp_path / "out"
    real_save = experiment._save_run
    saved = []

    def save(path, board):
        if saved:
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        real_save(path, board)
        saved.append(path)

    monkeypatch.setattr(experiment, "_save_run", save)
    assert experiment.main(_args(short, out)) == 2
    err = capsys.readouterr().err
    assert "No space left on device" in err and "--resume" in err
    assert counted == [1, 2]                         # stopped at the first result it could not keep
    first = json.loads(saved[0].read_text())
    assert first["seed"] == 1 and first["frames"] > 0 and not (out / "results.md").exists()

    monkeypatch.setattr(experiment, "_save_run", real_save)
    counted.clear()
    assert experiment.main(_args(short, out, "--resume")) == 0
    assert counted == [2, 3]                         # seed 1 was kept, not run again
    runs = sorted(p.name for p in (out / "runs").glob("*.json"))
    assert runs == [f"short__sensor__seed{s}.json" for s in (1, 2, 3)]
    table = (out / "results.md").read_text()
    assert "| short |" in table
    # the versions the figures were measured with, beside them: the same code moves with its libraries
    env = json.loads((out / "environment.json").read_text())
    assert env["libraries"]["numpy"] == np.__version__ and env["libraries"]["opencv-python-headless"]
    assert env["python"] == platform.python_version()
    assert f"numpy {np.__version__}" in table and f"Python {platform.python_version()}" in table
