"""The field file: the shipped Tipping Point layout and clear errors for bad files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from jetson.autonomy.geometry import INCH
from sim.errors import FieldError
from sim.field import load_field, parse_field, resolve_field_path


def test_tipping_point_counts_and_units() -> None:
    f = load_field("tipping_point")
    assert f.size == pytest.approx(144 * INCH)
    assert len(f.ring_positions) == 42
    assert f.ring.total == 72
    assert len(f.goals) == 7
    kinds = sorted(g.kind for g in f.goals)
    assert kinds.count("alliance") == 4 and kinds.count("neutral") == 2
    assert kinds.count("neutral_tall") == 1
    assert sorted(g.alliance for g in f.goals if g.alliance) == ["blue", "blue", "red", "red"]
    assert {p.alliance for p in f.platforms} == {"red", "blue"}
    assert f.rules.interaction_s == 105.0 and f.rules.pin_time_s == 5.0
    assert np.all(np.abs(f.ring_positions) < f.half)


def test_layout_is_point_symmetric() -> None:
    """The official field is symmetric under a 180 degree rotation; so must ours be, or the
    alliance-symmetric observation would lie."""
    f = load_field()
    rings = f.ring_positions
    d = np.linalg.norm(rings[:, None] - (-rings)[None], axis=-1)
    assert d.min(axis=1).max() < 1e-9
    for g in f.goals:
        mirror = [h for h in f.goals if np.allclose(h.position, -np.array(g.position))]
        assert len(mirror) == 1
        other = mirror[0]
        assert other.kind == g.kind
        if g.alliance:
            assert other.alliance != g.alliance
    for s in f.starts:
        twin = f.start("blue" if s.alliance == "red" else "red", s.robot)
        assert np.allclose(twin.position, -np.array(s.position))
        assert (twin.heading - s.heading) % 360 == pytest.approx(180.0)


def test_ring_colour_is_inside_the_perception_window() -> None:
    from sim.camera import rgb_to_hsv_opencv

    f = load_field()
    h, s, v = rgb_to_hsv_opencv(np.array([[f.ring.rgb]], dtype=np.uint8))[0, 0]
    assert 123 <= h <= 169 and 39 <= s <= 192 and 76 <= v <= 255
    # A fully saturated purple would not be (REFERENCE section 7).
    h, s, v = rgb_to_hsv_opencv(np.array([[[153, 0, 204]]], dtype=np.uint8))[0, 0]
    assert s > 192


def test_unknown_field_name_lists_the_shipped_ones() -> None:
    with pytest.raises(FieldError, match="tipping_point"):
        load_field("spin_up_2077")


def test_missing_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(FieldError, match="does not exist"):
        resolve_field_path(tmp_path / "nope.toml")


def test_invalid_toml_is_reported(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("name = \n")
    with pytest.raises(FieldError, match="not valid TOML"):
        load_field(bad)


def _minimal() -> dict:
    import tomllib

    from sim.field import FIELD_DIR

    return tomllib.loads((FIELD_DIR / "tipping_point.toml").read_text())


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d["field"].update(size=-1), "field.size"),
        (lambda d: d["ring"].update(rgb=[300, 0, 0]), "ring.rgb"),
        (lambda d: d["ring"].update(positions=[[0.0, 500.0]]), "outside the field"),
        (lambda d: d["goals"][0].update(kind="bucket"), "goals\\[0\\].kind"),
        (lambda d: d["goals"][0].update(alliance="green"), "goals\\[0\\].alliance"),
        (lambda d: d["zones"].update(red_home=[1, 1, 0, 0]), "zones.red_home"),
        (lambda d: d.update(units="furlong"), "units"),
        (lambda d: d["ring"].update(inner_diameter=9.0), "inner_diameter"),
        (lambda d: d.pop("scoring"), "scoring"),
    ],
)
def test_bad_values_name_the_key(mutate, message: str) -> None:
    data = _minimal()
    mutate(data)
    with pytest.raises(FieldError, match=message):
        parse_field(data, source="test.toml")


def test_units_convert(tmp_path: Path) -> None:
    data = _minimal()
    f_in = parse_field(data)
    data["units"] = "m"
    f_m = parse_field(data)
    assert f_m.size == pytest.approx(f_in.size / INCH)
