#!/bin/sh
# Install the Jetson daemon as a service on a Jetson (or any Linux machine with systemd).
# Run from the repository checkout at /opt/pete, as root, after `pip install '.[jetson]'`
# into /opt/pete/.venv (jetson/README.md, "A fresh Jetson", steps 1-5). Safe to run again.
set -eu

ROOT=$(CDPATH= cd -- "$(dirname -- "$0")/../.." && pwd)
DEPLOY="$ROOT/jetson/deploy"

if [ "$(id -u)" -ne 0 ]; then
  echo "install.sh: run as root (sudo sh jetson/deploy/install.sh)" >&2
  exit 1
fi
if [ "$ROOT" != /opt/pete ]; then
  echo "install.sh: the unit runs /opt/pete/.venv/bin/pete-jetson, but this checkout is $ROOT;" >&2
  echo "            move it to /opt/pete or edit ExecStart in pete-jetson.service" >&2
  exit 1
fi
if [ ! -x /opt/pete/.venv/bin/pete-jetson ]; then
  echo "install.sh: /opt/pete/.venv/bin/pete-jetson is missing: create the venv first" >&2
  exit 1
fi

# A system user that may use serial ports (dialout) and cameras (video, plugdev).
if ! id pete >/dev/null 2>&1; then
  useradd --system --no-create-home --home-dir /var/lib/pete-jetson --shell /usr/sbin/nologin pete
fi
for group in dialout video plugdev; do
  getent group "$group" >/dev/null && usermod -aG "$group" pete
done

install -m 0644 "$DEPLOY/99-pete-brain.rules" /etc/udev/rules.d/99-pete-brain.rules
udevadm control --reload-rules
udevadm trigger --subsystem-match=tty

install -d -m 0755 /etc/pete-jetson
if [ ! -e /etc/pete-jetson/pete-jetson.toml ]; then
  install -m 0644 "$DEPLOY/pete-jetson.toml" /etc/pete-jetson/pete-jetson.toml
else
  echo "keeping the existing /etc/pete-jetson/pete-jetson.toml"
fi

# The unit keeps /opt read-only to the daemon (ProtectSystem=strict): compile the bytecode now.
/opt/pete/.venv/bin/python -m compileall -q "$ROOT/protocol" "$ROOT/jetson" >/dev/null || true

install -m 0644 "$DEPLOY/pete-jetson.service" /etc/systemd/system/pete-jetson.service
systemctl daemon-reload
systemctl enable pete-jetson.service
systemctl restart pete-jetson.service
# How exposed the hardened unit leaves the system (0 locked down .. 10 open; bench.deploy).
systemd-analyze security pete-jetson.service 2>/dev/null | tail -n 1 || true
echo "installed: follow it with  journalctl -u pete-jetson -f"
