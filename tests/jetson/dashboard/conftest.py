"""Fixtures of the dashboard's tests: a live daemon with its dashboard (stack.py)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.jetson.dashboard.stack import Live, live_stack, wait_for


@pytest.fixture
def live(tmp_path: Path) -> Iterator[Live]:
    with live_stack(tmp_path) as running:
        assert wait_for(lambda: running.daemon.counters.states >= 10), running.out.getvalue()
        # The dashboard's process starts beside the loop, which never waits for it.
        assert wait_for(lambda: running.dashboard_ready, 60.0), running.out.getvalue()
        yield running


@pytest.fixture
def stack(tmp_path: Path) -> Callable[..., Any]:
    """live_stack(tmp_path, ...) for tests that need another setup."""
    return lambda **kw: live_stack(tmp_path, **kw)


@pytest.fixture
def waiter() -> Callable[..., Any]:
    return wait_for
