"""Ports picked for processes started later: below the kernel's ephemeral range, never one held now."""

import random
import socket

import pytest

from uvteam.io.ports import LOWEST_PORT, ephemeral_range, free_port


class ScriptedPicks(random.Random):
    """A random source whose ``randrange(start, stop)`` is ``script(call number, start, stop)``; counts its calls."""

    def __init__(self, script):
        super().__init__(0)
        self.script, self.calls = script, 0

    def randrange(self, start, stop=None, step=1):
        self.calls += 1
        return self.script(self.calls, start, stop)


def test_the_ephemeral_range_is_read_from_the_kernel_or_is_ianas(tmp_path):
    f = tmp_path / "ip_local_port_range"
    f.write_text("32768\t60999\n")
    assert ephemeral_range(f) == (32768, 60999)
    assert ephemeral_range(tmp_path / "absent") == (49152, 65535)
    f.write_text("garbage")
    assert ephemeral_range(f) == (49152, 65535)


@pytest.mark.parametrize("kind", [socket.SOCK_STREAM, socket.SOCK_DGRAM])
def test_a_port_below_the_ephemeral_range_that_binds(kind):
    lo, _ = ephemeral_range()
    for _ in range(20):
        port = free_port(kind)
        if lo - LOWEST_PORT >= 1000:
            assert LOWEST_PORT <= port < lo
        with socket.socket(socket.AF_INET, kind) as s:
            s.bind(("127.0.0.1", port))   # free: what the process it is meant for does


def test_what_is_held_is_passed_over():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as held:
        held.bind(("127.0.0.1", 0))
        held_port = held.getsockname()[1]
        # the held port first, then the first port after it that binds
        pick = ScriptedPicks(lambda n, start, stop: held_port if n == 1 else start + n)
        port = free_port(socket.SOCK_DGRAM, rng=pick, ephemeral=(held_port + 2000, 60999))
        assert port != held_port and pick.calls >= 2


def test_a_port_named_already_is_not_named_again():
    """Two ports named before either process binds: free_port checks only what is held, so the caller passes
    what it named (the demo gave two UGVs' links one port once)."""
    first = free_port(socket.SOCK_DGRAM)

    def repeating():
        return ScriptedPicks(lambda n, start, stop: first if n < 3 else first + 1)

    pick = repeating()
    lo, _ = ephemeral_range()
    if lo - LOWEST_PORT < 1000:
        pytest.skip(f"no room below this machine's ephemeral range ({lo})")
    assert free_port(socket.SOCK_DGRAM, rng=repeating()) == first        # nothing holds it: named again
    assert free_port(socket.SOCK_DGRAM, rng=pick, taken={first}) == first + 1 and pick.calls == 3
    # the kernel's choice, when there is no room below its range, skips what was named too
    kernel = free_port(socket.SOCK_DGRAM, ephemeral=(1024, 65535))
    assert free_port(socket.SOCK_DGRAM, ephemeral=(1024, 65535), taken={kernel}) != kernel


def test_with_no_room_below_the_range_the_kernel_chooses():
    # a range that starts low leaves nothing to pick from: the kernel's own free port
    port = free_port(socket.SOCK_DGRAM, ephemeral=(1024, 65535))
    assert 0 < port < 65536
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", port))


def test_the_demo_takes_its_router_and_link_ports_below_the_ephemeral_range(tmp_path):
    from uvteam_ground.demo import DEFAULT_SCENARIO, Team  # noqa: PLC0415

    lo, _ = ephemeral_range()
    if lo - LOWEST_PORT < 1000:
        pytest.skip(f"no room below this machine's ephemeral range ({lo})")
    team = Team(str(DEFAULT_SCENARIO), workdir=str(tmp_path), frames="sensor")
    ports = [team.router_port, *team.ports.values()]
    assert len(ports) == 1 + 1 + len(team.ugvs)
    assert all(LOWEST_PORT <= p < lo for p in ports), ports
    assert len(set(ports)) == len(ports) and set(ports) <= team.named_ports, ports   # none named twice


def test_the_demo_names_no_port_twice_even_when_the_random_picks_repeat(tmp_path, monkeypatch):
    """The demo's router and links are named before any binds; picks that repeat (as random ones may: one run
    gave two UGVs' links the same port) are passed over, also the map's port chosen before the team."""
    import uvteam.io.ports as ports_module  # noqa: PLC0415
    from uvteam_ground.demo import DEFAULT_SCENARIO, Team  # noqa: PLC0415

    lo, _ = ephemeral_range()
    if lo - LOWEST_PORT < 1000:
        pytest.skip(f"no room below this machine's ephemeral range ({lo})")
    base = free_port()
    real = random.SystemRandom()

    def few_ports():
        """Three ports in turn, over and over: the team needs more, so picks repeat."""
        return ScriptedPicks(lambda n, start, stop: base + n % 3 if n < 40 else real.randrange(start, stop))

    monkeypatch.setattr(ports_module.random, "SystemRandom", few_ports)
    team = Team(str(DEFAULT_SCENARIO), workdir=str(tmp_path), frames="sensor", map_http=f"127.0.0.1:{base + 1}")
    ports = [team.router_port, *team.ports.values()]
    assert len(set(ports)) == len(ports) and base + 1 not in ports, ports
