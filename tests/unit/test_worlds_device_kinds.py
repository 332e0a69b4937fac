"""Device kinds declared once: their parameters read, written back and documented from the
declaration alone."""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest

from worlds import WorldError
from worlds.device_kinds import RobotContext, declare_device, device_kinds, read_params
from worlds.params import declared_params, param, param_docs, param_items
from worlds.reader import Table
from worlds.spec import DEVICE_NAMES, BodySpec, Position2dSpec

ROOT = Path(__file__).resolve().parents[2]
FILE = Path("x.toml")


@dataclass(frozen=True)
class _Beam:
    reach_m: float = param(0.5, "how far it reaches (m)", positive=True)
    spread_rad: float = param(0.25, "its spread", kind="angle", max=1.0)
    beams: int = param(3, "how many", min=1, max=9)
    label: str = param("front", "its name")


def test_keys_drop_unit_suffixes_and_angles_take_deg_or_rad() -> None:
    assert [k for _, k, _ in declared_params(_Beam)] == ["reach", "spread", "beams", "label"]
    t = Table(FILE, "robots[0].beam", {"reach": 2, "spread_deg": 10.0, "beams": 4})
    spec = read_params(_Beam, t)
    t.finish()
    assert spec == _Beam(2.0, pytest.approx(0.1745329), 4, "front")
    assert param_items(spec)[:2] == [("reach", 2.0), ("spread_rad", spec.spread_rad)]


@pytest.mark.parametrize(("data", "message"), [
    ({"reach": 0}, "robots[0].beam.reach: expected a number > 0, found 0"),
    ({"spread_deg": 90}, "robots[0].beam.spread_deg: expected an angle <= 57.2958 deg, found 90"),
    ({"beams": 1.5}, "robots[0].beam.beams: expected an integer, found 1.5"),
    ({"beams": 10}, "robots[0].beam.beams: expected an integer <= 9, found 10"),
    ({"label": 3}, "robots[0].beam.label: expected a string, found 3"),
])
def test_bad_values_say_key_expected_and_found(data: dict[str, object], message: str) -> None:
    with pytest.raises(WorldError) as err:
        read_params(_Beam, Table(FILE, "robots[0].beam", data))
    assert str(err.value) == f"x.toml: {message}"


def test_an_unknown_key_lists_the_known_ones() -> None:
    t = Table(FILE, "robots[0].beam", {"raech": 1})
    read_params(_Beam, t)
    with pytest.raises(WorldError, match=r"beam.raech: expected one of the known keys "
                                         r"\(beams, label, reach, spread_deg, spread_rad\)"):
        t.finish()


def test_a_kind_is_declared_once() -> None:
    with pytest.raises(ValueError, match="'position2d' is declared twice"):
        declare_device("position2d", doc="again")(_Beam)


def test_the_kinds_are_the_builtins_in_order_then_the_declared_modules() -> None:
    kinds = device_kinds()
    assert tuple(kinds)[:len(DEVICE_NAMES)] == DEVICE_NAMES
    assert "ir" in kinds and kinds["ir"].params.__module__ == "worlds.devices.ir"
    assert kinds["blobfinder"].needs == ("camera",) and kinds["power"].late


# (the bumper's writer gives each segment's x, y, yaw and length, not the Pioneer ring's
# curvature: a Pioneer bumper written out reads back with straight panels)
@pytest.mark.parametrize("name", sorted(set(device_kinds()) - {"bumper"}))
def test_every_kind_reads_its_defaults_and_writes_them_back(name: str) -> None:
    """An empty table is the defaults; what a kind writes it reads back unchanged."""
    kind = device_kinds()[name]
    ctx = RobotContext(BodySpec(), ())
    data: dict[str, object] = {"channels": ["red"]} if name == "blobfinder" else {}
    first = kind.read_table(Table(FILE, f"robots[0].{name}", data), ctx)
    text = "\n".join(f"{k} = {_toml(v)}" for k, v in kind.items(first))
    again = kind.read_table(Table(FILE, f"robots[0].{name}", tomllib.loads(text)), ctx)
    assert again == first


def _toml(v: object) -> str:
    if isinstance(v, tuple) and hasattr(v, "_fields"):  # a Mount
        return "{ " + ", ".join(f"{f} = {getattr(v, f)!r}" for f in ("x", "y", "z")) + (
            f", yaw_rad = {v.yaw!r} }}")  # type: ignore[attr-defined]
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    if isinstance(v, str):
        return f'"{v}"'
    return repr(v).lower() if isinstance(v, bool) else repr(v)


def test_param_docs_give_key_default_and_doc() -> None:
    assert param_docs(Position2dSpec)[:2] == [
        "`max_speed` (0.5): top speed (m/s)", "`max_yaw_rate_deg` (100.0): top turn rate (per s)"]


@pytest.mark.parametrize("name", [n for n in sorted(device_kinds()) if n not in DEVICE_NAMES])
def test_every_declared_key_of_a_new_kind_is_in_the_world_file_docs(name: str) -> None:
    text = (ROOT / "docs" / "sim.md").read_text(encoding="utf-8")
    assert f"`{name}`" in text
    for line in param_docs(device_kinds()[name].params):
        key = line.split("`")[1]
        assert f"`{key}`" in text, f"docs/sim.md does not give {name}'s {key}"
