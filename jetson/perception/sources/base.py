"""The one interface every camera source meets."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterator
from types import TracebackType

from jetson.perception.frame import Frame


class FrameSource(ABC):
    """Frames of aligned colour and depth, in order, until the source ends.

    read() returns the next frame, or None at the end of a recording or stream (a live camera
    never ends; it raises SourceError when it stops delivering). Sources are context managers
    and iterables: `with open_source(path) as src: for frame in src: ...`.
    """

    description: str = "frame source"

    @abstractmethod
    def read(self) -> Frame | None: ...

    def close(self) -> None:  # noqa: B027 - most sources have nothing to release
        """Release the device, file or socket; reading after close is an error."""

    def __iter__(self) -> Iterator[Frame]:
        while (frame := self.read()) is not None:
            yield frame

    def __enter__(self) -> FrameSource:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
