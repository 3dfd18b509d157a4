"""Every error the protocol package raises: one hierarchy under ProtocolError.

Each keeps the standard base it had before there was one hierarchy (ValueError for a bad schema
or frame, RuntimeError for a refused peer or a failed demonstration), so `except ValueError` and
`except RuntimeError` still catch what they caught. ErrorKind names why a frame was dropped.
"""

from __future__ import annotations

from protocol.compat import StrEnum


class ProtocolError(Exception):
    """Something on the wire or in the schema cannot be used; the message says what."""


class SchemaError(ProtocolError, ValueError):
    """The schema file is malformed; the message names the offending entry."""


class ErrorKind(StrEnum):
    """Why a frame was dropped; the C++ decoder counts the same kinds (pete::wire::Error)."""

    GARBAGE = "garbage"
    BAD_COBS = "bad_cobs"
    TRUNCATED = "truncated"
    BAD_CRC = "bad_crc"
    BAD_LENGTH = "bad_length"
    UNKNOWN_ID = "unknown_id"
    BAD_VALUE = "bad_value"
    WRONG_DIRECTION = "wrong_direction"
    OVERSIZE = "oversize"
    UNKNOWN_STREAM = "unknown_stream"


class FrameError(ProtocolError, ValueError):
    """A packet that cannot be decoded: `kind` says why, `detail` what was found."""

    def __init__(self, kind: ErrorKind, detail: str) -> None:
        super().__init__(f"{kind}: {detail}")
        self.kind = kind
        self.detail = detail


class FingerprintMismatch(ProtocolError, RuntimeError):
    """The peer was generated from another schema: it must not drive the robot."""


class DemoError(ProtocolError, RuntimeError):
    """Something in the demonstration did not behave as the protocol promises."""
