import socket
from pathlib import Path

import pytest

from uvteam.io.ports import free_port   # the demo's: below the ephemeral range, so no socket takes it first


@pytest.fixture
def udp_port():
    return free_port(socket.SOCK_DGRAM)


@pytest.fixture
def tcp_port():
    return free_port()


# The repository's own scenarios (scenarios/): those on real ground imagery read it from ../shared/data,
# which is never in the repository; a test that needs one skips, saying so, where it is absent.
OWN_SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"


def load_own_scenario(name: str):
    from uvteam.io.files import ImageryMissing, load_scenario  # noqa: PLC0415

    try:
        return load_scenario(OWN_SCENARIOS / f"{name}.toml")
    except ImageryMissing as exc:
        pytest.skip(f"scenarios/{name}.toml: its real ground imagery is not on this machine ({exc.key}: {exc.reason})")


DEMO_SCENARIO = Path(__file__).resolve().parents[1] / "services" / "uvteam_ground" / "data" / "demo.toml"


def record_experiment(path: Path, seed: int, duration_s: float, **recorder_kw):
    """``duration_s`` of the demo scenario in the experiment (the team's nodes over the in-memory bus),
    recorded to MCAP at ``path`` with the localizer's config; returns the team and the recorder's counts."""
    from uvteam.config import vehicle_config_to_toml  # noqa: PLC0415
    from uvteam.io.files import load_scenario  # noqa: PLC0415
    from uvteam.io.recording import McapRecorder, attach_in_memory  # noqa: PLC0415
    from uvteam_sim.experiment import SimTeam  # noqa: PLC0415

    team = SimTeam(load_scenario(DEMO_SCENARIO), seed, "sensor")
    loc = team.layout.localizer
    with McapRecorder(path, team.layout.team, clock=team.clock, **recorder_kw) as rec:
        rec.add_config(loc, vehicle_config_to_toml(team.cfgs[loc]))
        attach_in_memory(team.hub, team.layout.team, rec)
        team.run(duration_s)
        counts = dict(rec.counts)
    return team, counts
