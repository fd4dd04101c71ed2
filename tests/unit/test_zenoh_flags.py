"""zenoh's flags, the same on every command that opens a session: -m/--mode, -e/--connect, -l/--listen,
--zenoh-config and --cfg KEY:VALUE (zenoh's examples' syntax: a JSON5 value inserted at KEY)."""

import json
from importlib.metadata import entry_points

import pytest

from uvteam.bus import BusConfig
from uvteam.errors import ConfigError
from uvteam.io.zenoh_bus import parse_cfg, zenoh_config

SESSION_COMMANDS = ("uav", "ugv", "localizer", "sim", "tap", "bridge", "router", "map", "record", "replay", "demo")


@pytest.mark.parametrize("name", SESSION_COMMANDS)
def test_every_command_that_opens_a_session_takes_zenohs_flags(name, capsys):
    main = {ep.name: ep for ep in entry_points(group="uvteam.commands")}[name].load()
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    for flag in ("--mode", "-m", "--connect", "-e ENDPOINT", "--listen", "-l ENDPOINT", "--cfg KEY:VALUE",
                 "--zenoh-config"):
        assert flag in text, (name, flag)


@pytest.mark.parametrize("items, pairs", [
    ([], ()),                                                                   # none given
    (["transport/link/tx/lease:5000"], (("transport/link/tx/lease", "5000"),)),  # a number
    (['connect/endpoints:["tcp/10.0.0.1:7447"]'], (("connect/endpoints", '["tcp/10.0.0.1:7447"]'),)),  # the
    #                                                                             first colon splits; JSON5 keeps its own
    (["mode:'client'"], (("mode", "'client'"),)),                              # JSON5 single quotes
])
def test_parse_cfg(items, pairs):
    assert parse_cfg(items) == pairs


@pytest.mark.parametrize("item", ["lease", ":5", "transport/link/tx/lease:", " : "])   # no colon, key or value
def test_parse_cfg_refuses(item):
    with pytest.raises(ConfigError, match="KEY:VALUE"):
        parse_cfg([item])


def test_cfg_is_inserted_last_over_the_flags():
    conf = zenoh_config(BusConfig(mode="peer", listen=("tcp/127.0.0.1:7999",),
                                  cfg=(("transport/link/tx/lease", "5000"),
                                       ("listen/endpoints", '["tcp/127.0.0.1:7998"]'))))
    assert json.loads(conf.get_json("transport/link/tx/lease")) == 5000
    assert json.loads(conf.get_json("listen/endpoints")) == ["tcp/127.0.0.1:7998"]


@pytest.mark.parametrize("pair", [("transport/link/tx/leese", "5000"),      # a typo in the key
                                  ("transport/link/tx/lease", "soon")])      # not a number
def test_cfg_that_zenoh_refuses_names_the_key(pair):
    with pytest.raises(ConfigError) as exc:
        zenoh_config(BusConfig(cfg=(pair,)))
    assert exc.value.source == "--cfg" and exc.value.key == pair[0]


def test_a_bad_cfg_is_a_configuration_error_at_start_up(capsys):
    from uvteam_ground.tap import main as tap

    assert tap(["--cfg", "nonsense", "--duration", "0.1"]) == 2
    assert "KEY:VALUE" in capsys.readouterr().err
