"""Finding the Brain's user port among the machine's serial ports."""

from __future__ import annotations

from dataclasses import dataclass

from jetson.ports import VEX_VID, classify_v5_ports


@dataclass
class FakePort:
    device: str
    vid: int | None
    description: str | None = None
    location: str | None = None


def test_user_port_found_by_description_and_listed_first() -> None:
    ports = [
        FakePort("/dev/ttyACM0", VEX_VID, "VEX Robotics V5 Brain - System"),
        FakePort("/dev/ttyACM1", VEX_VID, "VEX Robotics V5 Brain - User"),
        FakePort("/dev/ttyUSB0", 0x0403, "FTDI"),
    ]
    found = classify_v5_ports(ports)
    assert [(p.device, p.kind) for p in found] == [
        ("/dev/ttyACM1", "user"),
        ("/dev/ttyACM0", "system"),
    ]


def test_user_port_found_by_interface_location() -> None:
    ports = [
        FakePort("/dev/ttyACM3", VEX_VID, "V5", "1-1.2:1.2"),
        FakePort("/dev/ttyACM2", VEX_VID, "V5", "1-1.2:1.0"),
    ]
    assert classify_v5_ports(ports)[0].device == "/dev/ttyACM3"


def test_two_unlabelled_ports_fall_back_to_the_higher_numbered() -> None:
    ports = [FakePort("/dev/ttyACM1", VEX_VID), FakePort("/dev/ttyACM0", VEX_VID)]
    found = classify_v5_ports(ports)
    assert (found[0].device, found[0].kind) == ("/dev/ttyACM1", "user")
    assert (found[1].device, found[1].kind) == ("/dev/ttyACM0", "system")


def test_no_vex_device_means_no_ports() -> None:
    assert classify_v5_ports([FakePort("/dev/ttyUSB0", 0x0403, "FTDI User")]) == []
