"""The live dashboard: what the robot sees, knows and decides, in a browser (README.md here).

snapshot.py   the daemon's side: Observer (a snapshot built on the daemon's thread when asked)
server.py     the web server on its own thread (aiohttp): the page, a WebSocket of updates
system.py     the Jetson's CPU, memory, temperature and disk
replay.py     a session recording as a timeline of the same snapshots
report.py     `pete-jetson report`: plots of a session
cli.py        `pete-jetson dashboard` and `pete-jetson report`
static/       the page: HTML, a canvas and plain JavaScript, no build step, no CDN
"""
