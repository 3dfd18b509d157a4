"""The field file's whole-game tables: loaded in metres, optional for other fields, checked."""

from __future__ import annotations

import copy
import math
import tomllib

import pytest

from sim.errors import FieldError
from sim.field import FIELD_DIR, SeesawSpec, load_field, parse_field

INCH = 0.0254


def raw() -> dict:
    return tomllib.loads((FIELD_DIR / "tipping_point.toml").read_text())


def test_the_whole_game_tables_load() -> None:
    f = load_field()
    assert f.seesaw.hinge_flat == pytest.approx(2 * INCH)
    assert f.seesaw.climb_edge == pytest.approx(1 * INCH)
    assert f.seesaw.overhang == pytest.approx(3 * INCH)
    assert f.seesaw.start_down == "field"
    assert f.rules.endgame_s == 30.0 and f.rules.platform_foul_credit == 1
    assert f.rules.elevated_robots_max == 2
    assert f.rules.isolation_contact_foul and f.rules.isolation_foul_forfeits
    assert not f.rules.isolation_home_zone_foul
    assert (f.scoring.autonomous_bonus, f.scoring.autonomous_bonus_tie) == (20, 10)
    names = [g.name for g in f.goals]
    assert names[f.awp_goals["red"]] == "red_south" and names[f.awp_goals["blue"]] == "blue_north"
    for alliance, line in f.awp_lines.items():  # each line runs through its goal's start
        g = f.goals[f.awp_goals[alliance]]
        x0, y0, x1, y1 = line
        assert y0 == y1 == pytest.approx(g.position[1]) and min(x0, x1) < g.position[0] < max(
            x0, x1
        )
    for g in f.goals:
        assert g.has_high_branch == (g.kind != "alliance")
    red = f.platform("red")
    assert red.field_side == 1.0 and f.platform("blue").field_side == -1.0
    assert red.along(red.center[0] + 0.1) == pytest.approx(0.1)
    assert math.degrees(red.max_tilt_rad) == pytest.approx(14.48, abs=0.01)
    assert red.edge_height(0.0) == pytest.approx(red.height)


def test_a_field_without_them_gets_the_defaults() -> None:
    data = raw()
    del data["seesaw"]
    for key in (
        "endgame_s",
        "platform_foul_credit",
        "elevated_robots_max",
        "isolation_contact_foul",
    ):
        del data["rules"][key]
    del data["scoring"]["autonomous_bonus_tie"]
    for key in ("red_awp_line", "red_awp_goal", "blue_awp_line", "blue_awp_goal"):
        del data["zones"][key]
    for kind in data["goal_kinds"].values():
        kind.pop("branch_capacity")
        kind.pop("high_branch_capacity")
    f = parse_field(data)
    assert f.seesaw == SeesawSpec()
    assert f.rules.endgame_s == 30.0 and f.scoring.autonomous_bonus_tie == 10
    assert f.rules.elevated_robots_max == 2
    assert f.awp_lines == {} and f.awp_goals == {}
    assert not any(g.has_high_branch for g in f.goals)


@pytest.mark.parametrize(
    ("edit", "key"),
    [
        (lambda d: d["seesaw"].update(start_down="up"), "seesaw.start_down"),
        (lambda d: d["seesaw"].update(board_mass_kg=0), "seesaw.board_mass_kg"),
        (lambda d: d["zones"].update(red_awp_goal="nowhere"), "zones.red_awp_goal"),
        (lambda d: d["rules"].update(isolation_contact_foul="yes"), "rules.isolation_contact_foul"),
        (lambda d: d["rules"].update(elevated_robots_max=-1), "rules.elevated_robots_max"),
        (lambda d: d["goal_kinds"]["neutral"].update(high_branch_capacity=-1), "high_branch"),
    ],
)
def test_bad_values_name_their_key(edit, key: str) -> None:  # type: ignore[no-untyped-def]
    data = copy.deepcopy(raw())
    edit(data)
    with pytest.raises(FieldError, match=key):
        parse_field(data)
