"""I/O adapters: the only modules of the core that touch zenoh, MAVLink, cameras and files.

- :mod:`.zenoh_bus`  the :class:`uvteam.bus.Bus` over an eclipse-zenoh session; zenoh's CLI flags
- :mod:`.mavlink`    the :class:`uvteam.autopilot.Autopilot` over MAVLink 2 (UDP, TCP, serial)
- :mod:`.video`      camera devices, streams and video files as frame sources
- :mod:`.files`      vehicle configs, scenarios and signing keys read from disk

Everything else in ``uvteam`` is a pure function of its inputs, or service logic that is handed its
bus, autopilot and clock (:mod:`uvteam.nodes`); the service shells (``services/``) and
:mod:`uvteam.service` wire the two together.
"""
