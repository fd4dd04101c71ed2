"""Every error uvteam raises on purpose.

    UvteamError
     +-- ConfigError     bad configuration: names the file, the key and the reason; raised at start-up
     +-- MessageError    a payload that does not decode to a valid message: names the field, what was
     |                   expected and what came
     +-- LinkError       an autopilot or bus link that cannot be opened or has gone away

Geometry never raises for degenerate input: it returns a typed failure value
(:class:`uvteam.homography.FitFailure`) so that callers must look at it.
"""

from __future__ import annotations

__all__ = ["UvteamError", "ConfigError", "MessageError", "LinkError"]


class UvteamError(Exception):
    """Base of every error uvteam raises on purpose."""


class ConfigError(UvteamError):
    def __init__(self, source: str, key: str, reason: str) -> None:
        super().__init__(f"{source}: {key}: {reason}")
        self.source, self.key, self.reason = source, key, reason


class MessageError(UvteamError):
    def __init__(self, schema: str, field: str, reason: str) -> None:
        super().__init__(f"{schema}: field {field!r}: {reason}")
        self.schema, self.field, self.reason = schema, field, reason


class LinkError(UvteamError):
    """An I/O link (MAVLink, zenoh, camera) failed; `where` names it."""

    def __init__(self, where: str, reason: str) -> None:
        super().__init__(f"{where}: {reason}")
        self.where, self.reason = where, reason
