"""Headless Chromium for the dashboard's checks: Debian's `chromium` and `chromium-driver` (the
Makefile installs them), driven by Selenium with the driver given by path, so nothing is ever
downloaded. Used by tests/jetson/dashboard/test_browser.py and bench/dashboard.py.

    with Browser() as b:
        b.open(url)
        b.wait(lambda: b.js("return D.state !== null"))
        b.screenshot(path)

`python -m bench.browser` only says whether a browser is available.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

CHROMIUM = ("/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome")
DRIVERS = ("/usr/bin/chromedriver", "/usr/lib/chromium/chromedriver")


def find_browser() -> tuple[str, str] | None:
    """(chromium, chromedriver) paths, or None when either is missing."""
    chrome = next((p for p in CHROMIUM if Path(p).exists()), None) or shutil.which("chromium")
    driver = next((p for p in DRIVERS if Path(p).exists()), None) or shutil.which("chromedriver")
    if chrome is None or driver is None:
        return None
    return chrome, driver


def missing_reason() -> str | None:
    """Why the browser checks cannot run here, or None when they can."""
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install -e '.[dev]')"
    if find_browser() is None:
        return "Debian's chromium and chromium-driver are not installed (make browser-deps)"
    return None


class Browser:
    """One headless Chromium window (1400x1000)."""

    def __init__(self, width: int = 1400, height: int = 1000) -> None:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service

        found = find_browser()
        if found is None:
            raise RuntimeError(missing_reason() or "no browser")
        chrome, driver = found
        opts = webdriver.ChromeOptions()
        opts.binary_location = chrome
        for arg in (
            "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
            f"--window-size={width},{height}", "--hide-scrollbars", "--mute-audio",
            "--no-first-run", "--disable-extensions", "--disable-background-networking",
        ):  # fmt: skip
            opts.add_argument(arg)
        self.driver = webdriver.Chrome(service=Service(driver), options=opts)
        self.driver.set_script_timeout(10)

    def pids(self) -> list[int]:
        """The browser's processes: chromedriver and everything under it."""
        root = self.driver.service.process.pid
        children: dict[int, list[int]] = {}
        for stat in Path("/proc").glob("[0-9]*/stat"):
            try:
                pid, rest = stat.read_text().split(" (", 1)
                ppid = int(rest.rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
            children.setdefault(ppid, []).append(int(pid))
        out, todo = [], [root]
        while todo:
            pid = todo.pop()
            out.append(pid)
            todo += children.get(pid, [])
        return out

    def threads(self) -> list[int]:
        """Every thread of the browser's processes: Linux schedules each on its own (its own
        niceness, CPUs and policy), and a call given a process's id changes its first thread
        only."""
        out = []
        for pid in self.pids():
            try:
                out += [int(t.name) for t in Path(f"/proc/{pid}/task").iterdir()]
            except OSError:  # it ended meanwhile
                continue
        return out

    def pin(self, cpus: set[int]) -> None:
        """Keep the browser's threads on `cpus` (a benchmark keeps it off the daemon's)."""
        for tid in self.threads():
            with contextlib.suppress(OSError):  # it ended meanwhile
                os.sched_setaffinity(tid, cpus)

    def renice(self, nice: int = 19) -> None:
        """Give the browser's processes the lowest priority (a benchmark: it stands for a
        laptop's browser, which does not share the robot's CPU)."""
        for tid in self.threads():
            with contextlib.suppress(OSError):
                os.setpriority(os.PRIO_PROCESS, tid, nice)

    def open(self, url: str) -> None:
        self.driver.get(url)

    def before_each_page(self, script: str) -> None:
        """Run `script` in every page this browser opens from now on, before the page's own
        scripts (Chrome DevTools' Page.addScriptToEvaluateOnNewDocument)."""
        self.driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": script})

    def js(self, script: str, *args: Any) -> Any:
        """Run `script` in the page with `D` bound to window.peteDashboard."""
        return self.driver.execute_script("const D = window.peteDashboard;\n" + script, *args)

    def text(self, element_id: str) -> str:
        return self.js("return document.getElementById(arguments[0]).textContent", element_id)

    def wait(self, cond: Callable[[], Any], timeout_s: float = 15.0, what: str = "") -> Any:
        deadline = time.monotonic() + timeout_s
        while True:
            got = cond()
            if got:
                return got
            if time.monotonic() > deadline:
                raise TimeoutError(f"the page did not show {what or 'it'} within {timeout_s} s")
            time.sleep(0.05)

    def screenshot(self, path: Path) -> Path:
        path.parent.mkdir(parents=True, exist_ok=True)
        self.driver.save_screenshot(str(path))
        return path

    def close(self) -> None:
        self.driver.quit()

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


if __name__ == "__main__":
    reason = missing_reason()
    print(reason or "headless Chromium: %s, driver %s" % find_browser())  # noqa: UP031
    sys.exit(0)
