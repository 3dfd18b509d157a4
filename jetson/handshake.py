"""The Hello handshake, Jetson side (protocol/README.md section 7).

We send Hello when the port opens and every `hello_period_s` until the Brain's Hello carries our
schema fingerprint; then the link is up and Commands may flow. A Brain with another fingerprint is
refused loudly and never commanded; we keep sending Hello (once a second) so that its log says why
too. A Brain Hello with a new boot id means the Brain restarted: it is answered at once.

Why replies are rate limited: the Brain answers every Jetson Hello with one Hello. Answering each
of its Hellos would ping-pong forever, so a Brain Hello is answered only when its boot id is new,
or when our last Hello is old enough that this one cannot be the answer to it (then the Brain is
still waiting for us: our Hello was lost).
"""

from __future__ import annotations

import types
from dataclasses import dataclass

from protocol import messages
from protocol.compat import StrEnum
from protocol.errors import FingerprintMismatch
from protocol.framing import check_hello
from protocol.messages import Hello, Role


class LinkState(StrEnum):
    WAITING = "waiting"  # no Hello from the Brain yet
    UP = "up"  # the Brain's Hello matched: Commands may flow
    MISMATCH = "mismatch"  # the Brain runs another schema: never command it


@dataclass(frozen=True)
class HelloOutcome:
    """What one Brain Hello changed. kind: up | restart | mismatch | same | refused."""

    kind: str
    reply: bool
    message: str


class Handshake:
    def __init__(
        self,
        boot_id: int,
        software_version: str,
        fingerprint: int = messages.FINGERPRINT,
        protocol_version: int = messages.PROTOCOL_VERSION,
        hello_period_s: float = 0.2,
        mismatch_period_s: float = 1.0,
    ) -> None:
        self.boot_id = boot_id & 0xFFFFFFFF
        self.software_version = software_version
        self.fingerprint = fingerprint
        self.protocol_version = protocol_version
        self.hello_period_s = hello_period_s
        self.mismatch_period_s = mismatch_period_s
        # check_hello reads the fingerprint from a codec; a namespace lets tests play another
        # schema without generating one.
        self._codec = types.SimpleNamespace(
            FINGERPRINT=fingerprint, PROTOCOL_VERSION=protocol_version
        )
        self.state = LinkState.WAITING
        self.brain_boot_id: int | None = None
        self.brain_fingerprint: int | None = None  # the schema fingerprint of the Brain's Hello
        self.brain_software = ""
        self.last_sent_s: float | None = None
        self.mismatch_message = ""

    def reset(self) -> None:
        """A new connection: nothing is known about whoever is at the other end."""
        self.state = LinkState.WAITING
        self.brain_boot_id = None
        self.brain_fingerprint = None
        self.brain_software = ""
        self.last_sent_s = None
        self.mismatch_message = ""

    @property
    def up(self) -> bool:
        return self.state is LinkState.UP

    def hello(self) -> Hello:
        return Hello(
            self.fingerprint, self.protocol_version, Role.JETSON, self.boot_id,
            self.software_version,
        )  # fmt: skip

    def due(self, now_s: float) -> bool:
        """Whether a Hello should go out now (call sent() after sending it)."""
        if self.state is LinkState.UP:
            return False
        if self.last_sent_s is None:
            return True
        period = self.mismatch_period_s if self.state is LinkState.MISMATCH else self.hello_period_s
        return now_s - self.last_sent_s >= period

    def sent(self, now_s: float) -> None:
        self.last_sent_s = now_s

    def on_hello(self, hello: Hello, now_s: float) -> HelloOutcome:
        if hello.role is not Role.BRAIN:
            # Our own Hello coming back means the port echoes (not raw) or is looped back.
            return HelloOutcome(
                "refused", False, f"ignored a Hello with role {hello.role.name.lower()}: "
                "is the port echoing our own bytes back?",
            )  # fmt: skip
        new_boot = hello.boot_id != self.brain_boot_id
        old_state = self.state
        self.brain_boot_id = hello.boot_id
        self.brain_fingerprint = hello.fingerprint
        self.brain_software = hello.software_version
        stale_ours = self.last_sent_s is None or now_s - self.last_sent_s >= self.hello_period_s / 2
        try:
            check_hello(hello, self._codec)
        except FingerprintMismatch as exc:
            self.state = LinkState.MISMATCH
            self.mismatch_message = str(exc)
            first = new_boot or old_state is not LinkState.MISMATCH
            return HelloOutcome("mismatch" if first else "same", new_boot, str(exc))
        self.state = LinkState.UP
        self.mismatch_message = ""
        desc = f"brain boot {hello.boot_id:08X} software {hello.software_version!r}"
        if old_state is LinkState.UP and new_boot:
            return HelloOutcome("restart", True, f"brain restarted: {desc}")
        if old_state is not LinkState.UP:
            # Ours may still be in flight; if it was lost, the Brain's next periodic Hello finds
            # ours stale and is answered.
            return HelloOutcome("up", stale_ours, f"link up: {desc}")
        return HelloOutcome("same", stale_ours, "")
