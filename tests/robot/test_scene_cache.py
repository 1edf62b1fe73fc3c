"""The scene's MJCF text from the user's cache: made once, then read, and made again whenever what it depends on
changes or a file it names has gone."""

from __future__ import annotations

from pathlib import Path

import mujoco

from robot.model.scene_cache import cached_scene_xml


class Maker:
    """Counts how often the text had to be made."""

    def __init__(self, text: str) -> None:
        self.text, self.calls = text, 0

    def __call__(self) -> str:
        self.calls += 1
        return self.text


def test_made_once_then_read_and_made_again_for_another_recipe(tmp_path: Path) -> None:
    make = Maker('<mujoco model="a"/>')
    assert cached_scene_xml("seed0", "world 0", make, tmp_path) == make.text
    assert cached_scene_xml("seed0", "world 0", make, tmp_path) == make.text
    assert make.calls == 1
    other = Maker('<mujoco model="b"/>')
    assert cached_scene_xml("seed0", "world 1", other, tmp_path) == other.text and other.calls == 1
    assert not list(tmp_path.glob("*.part"))  # written whole, nothing half-done left behind


def test_a_copy_naming_a_mesh_that_is_gone_is_made_again(tmp_path: Path) -> None:
    mesh = tmp_path / "meshes" / "hand.msh"
    mesh.parent.mkdir()
    mesh.write_bytes(b"x")
    make = Maker(f'<mujoco><compiler meshdir="{mesh.parent}"/><asset><mesh file="hand.msh"/></asset></mujoco>')
    cached_scene_xml("seed0", "r", make, tmp_path / "cache")
    cached_scene_xml("seed0", "r", make, tmp_path / "cache")
    assert make.calls == 1
    mesh.unlink()
    cached_scene_xml("seed0", "r", make, tmp_path / "cache")
    assert make.calls == 2


def test_without_a_writable_cache_the_text_is_still_made(tmp_path: Path) -> None:
    blocked = tmp_path / "file"
    blocked.write_text("")  # a file where the directory would go
    make = Maker("<mujoco/>")
    assert cached_scene_xml("seed0", "r", make, blocked / "scenes") == "<mujoco/>"
    assert cached_scene_xml("seed0", "r", make, blocked / "scenes") == "<mujoco/>" and make.calls == 2


def test_the_scene_read_back_is_the_one_written_and_compiles_with_the_drawn_robot(tmp_path: Path) -> None:
    from robot.model import humanoid_v1, op3
    from robot.model.scene import build_scene_spec
    from robot.model.world import generate_world

    def write() -> str:
        spec = build_scene_spec(generate_world(2))
        spec.meshdir = str(op3.op3_asset_dir() / "assets")
        return spec.to_xml()

    first = cached_scene_xml("seed2", "world 2", write, tmp_path)
    again = cached_scene_xml("seed2", "world 2", lambda: "not made again", tmp_path)
    assert again == first
    model = mujoco.MjModel.from_xml_string(again)
    assert any(int(model.geom_group[g]) == humanoid_v1.DETAILED_MESH_GROUP for g in range(model.ngeom))
