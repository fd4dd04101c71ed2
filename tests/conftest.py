import socket

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
