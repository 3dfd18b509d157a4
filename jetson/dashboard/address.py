"""`[HOST:]PORT`, the dashboard's address (standard library only: the settings check it)."""

from __future__ import annotations

DEFAULT_HOST = "127.0.0.1"


def parse_address(text: str, default_host: str = DEFAULT_HOST) -> tuple[str, int]:
    """`[HOST:]PORT` -> (host, port); a port alone listens on `default_host`, port 0 on a free
    port. An IPv6 host goes in brackets: `[::1]:8080`."""
    text = str(text).strip()
    host, sep, port_text = text.rpartition(":")
    if not sep:
        host, port_text = default_host, text
    if ":" in host and not (host.startswith("[") and host.endswith("]")):
        raise ValueError(f"dashboard address {text!r}: put an IPv6 host in brackets, [::1]:8080")
    host = host.strip("[]") or default_host
    try:
        port = int(port_text)
    except ValueError:
        raise ValueError(f"dashboard address {text!r}: expected [HOST:]PORT") from None
    if not 0 <= port <= 65535:
        raise ValueError(f"dashboard address {text!r}: port {port} out of range 0..65535")
    return host, port


def page_url(host: str, port: int) -> str:
    """Where a browser on this machine finds the page served on host:port (an address that
    listens everywhere is reached on the loopback)."""
    shown = f"[{host}]" if ":" in host else host
    if shown in ("0.0.0.0", "[::]"):
        shown = "127.0.0.1"
    return f"http://{shown}:{port}/"
