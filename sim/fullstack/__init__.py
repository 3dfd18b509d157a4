"""The full-stack match: the real Brain core (brain_host), the real wire and the real Jetson daemon
driving the simulated robot. sim/fullstack/README.md is the manual.

    brain_host.py  a Python driver for brain_host in lockstep (side channel, pty)
    cable.py       the USB cable between the two: forwards bytes, counts messages, injects faults
    hardware.py    the bridge World <-> Brain: GPS, wheel motors, encoders, competition status
    daemon.py      the Jetson daemon in-process on the simulated clock, its camera on a frame stream
    options.py     what a match is asked for (MatchOptions), the loop period, and RunningMatch: what
                   a fault scenario needs of the running match
    runner.py      one match, --stack full or --stack sim, lockstep or realtime
    faults.py      the fault scenarios (--fault NAME)
    report.py      the run folder: summary table, replay GIF with the camera inset, plots

Importing this package imports none of them.
"""
