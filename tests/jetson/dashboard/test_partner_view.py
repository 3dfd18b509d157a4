"""The dashboard's partner (jetson.dashboard.snapshot.partner_view): the VEXlink link as the Brain
reports it and the partner's newest report, in the page's units."""

from __future__ import annotations

from protocol.messages import Partner, PartnerFlags, PartnerLink, PartnerStatus, TargetKind


def report(**kw: object) -> Partner:
    base = dict(
        x_mm=-900, y_mm=350, heading_cdeg=27050, flags=PartnerFlags.POSE_OK | PartnerFlags.DRIVING,
        goal=255, rings=4, target=TargetKind.GOAL, target_id=3, target_x_mm=600,
        target_y_mm=-1200, match_ms=4000,
    )  # fmt: skip
    base.update(kw)
    return Partner(**base)  # type: ignore[arg-type]


def test_no_word_from_the_brain_is_no_partner() -> None:
    from jetson.dashboard.snapshot import partner_view

    assert partner_view(None, None, 1000) is None


def test_the_link_and_the_report_in_metres_and_degrees() -> None:
    from jetson.dashboard.snapshot import partner_view

    v = partner_view(report(), PartnerStatus(PartnerLink.UP, 40, 12, 13, 0, 1, 2), 4180)
    assert v is not None
    assert (v["link"], v["age_ms"], v["received"], v["sent"], v["lost"], v["errors"]) == (
        "up", 40, 12, 13, 1, 2,
    )  # fmt: skip
    r = v["report"]
    assert r["pose"] == [-0.9, 0.35, 270.5]
    assert r["rings"] == 4 and r["driving"] and not r["holding"] and not r["alone"]
    assert r["target"] == "goal" and r["target_xy"] == [0.6, -1.2]
    assert r["delay_ms"] == 180  # by the two match clocks


def test_a_report_without_a_pose_or_target_shows_neither() -> None:
    from jetson.dashboard.snapshot import partner_view

    flags = PartnerFlags.HOLDING_GOAL | PartnerFlags.ALONE
    v = partner_view(report(flags=flags, target=TargetKind.NOTHING, rings=255), None, None)
    assert v is not None and v["link"] is None
    r = v["report"]
    assert r["pose"] is None and r["target_xy"] is None and r["rings"] is None
    assert r["holding"] and r["alone"] and r["delay_ms"] is None


def test_a_lost_link_with_no_report_for_ever_says_so() -> None:
    from jetson.dashboard.snapshot import partner_view

    v = partner_view(None, PartnerStatus(PartnerLink.LOST, 0xFFFF, 9, 9, 0, 0, 0), 5000)
    assert v is not None
    assert v["link"] == "lost" and v["age_ms"] is None and v["report"] is None
