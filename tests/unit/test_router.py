"""Where `uvteam router` listens: --listen, else its config file's endpoints, else tcp/0.0.0.0:7447."""

import pytest

from uvteam_ground.router import DEFAULT_LISTEN, router_bus_config


@pytest.mark.parametrize(
    "file_text, flags, want_listen, want_endpoints",
    [
        (None, (), DEFAULT_LISTEN, DEFAULT_LISTEN),                                     # nothing: the default
        (None, ("tcp/127.0.0.1:1",), ("tcp/127.0.0.1:1",), ("tcp/127.0.0.1:1",)),       # the flag
        ('{listen:{endpoints:["tcp/127.0.0.1:2"]}}', (), (), ("tcp/127.0.0.1:2",)),     # the file's, untouched
        ('{listen:{endpoints:["tcp/127.0.0.1:2"]}}', ("tcp/127.0.0.1:1",),              # the flag beats the file
         ("tcp/127.0.0.1:1",), ("tcp/127.0.0.1:1",)),
        ('{listen:{endpoints:{router:["tls/127.0.0.1:3"]}}}', (), (), ("tls/127.0.0.1:3",)),   # per-mode form
        ('{mode:"router"}', (), DEFAULT_LISTEN, DEFAULT_LISTEN),                        # a file without endpoints
    ],
)
def test_router_listens_flag_then_file_then_default(tmp_path, file_text, flags, want_listen, want_endpoints):
    path = None
    if file_text is not None:
        path = tmp_path / "r.json5"
        path.write_text(file_text)
    cfg, endpoints = router_bus_config(str(path) if path else None, (), flags)
    assert cfg.listen == want_listen and endpoints == want_endpoints and cfg.mode == "router"


def test_router_config_file_missing_is_a_config_error(tmp_path):
    from uvteam.errors import ConfigError

    with pytest.raises(ConfigError) as e:
        router_bus_config(str(tmp_path / "nope.json5"), (), ())
    assert "nope.json5" in str(e.value)
