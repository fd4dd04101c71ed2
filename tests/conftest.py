import socket
from pathlib import Path

import pytest


def free_port(kind=socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


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
