"""Which device of which Stage model each Player address serves: from a `.cfg` or a world.

Pure. `plan_from_cfg` follows the configuration file exactly (every `stage` block's
`provides`, Player's `rangertolaser`); `plan_from_world` gives one port per position model,
in file order. A binding's `device` names what serves it: a `DeviceSet` slot ("position2d",
"laser", ...), "simulation", or a view: "laser_ranger" (a laser as a ranger), "sonar_ranger"
(a sonar array as a ranger).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from worlds.player_cfg import Address, DriverBlock, PlayerConfig
from worlds.stage.convert import StageWorld
from worlds.stage.syntax import StageError, Where
from worlds.stage.tree import Warnings

__all__ = ["Binding", "ServePlan", "plan_from_cfg", "plan_from_world"]

#: interfaces a stage block serves straight from the model's device of the same name
DIRECT = frozenset({"position2d", "blobfinder", "fiducial", "camera", "gripper", "bumper",
                    "power", "ptz", "sonar", "laser"})
_RANGER_VIEW = {"sonar": "sonar_ranger", "laser": "laser_ranger", "ranger": "ranger"}


@dataclass(frozen=True)
class Binding:
    address: Address
    model: str  # "" for simulation
    device: str


@dataclass(frozen=True)
class ServePlan:
    worldfile: Path
    bindings: tuple[Binding, ...]
    warnings: tuple[str, ...]

    def ports(self) -> list[int]:
        """The ports in the order they first appear."""
        return list(dict.fromkeys(b.address.port for b in self.bindings))


def worldfile_of(cfg: PlayerConfig) -> Path:
    """The worldfile of the first stage block that has one (StageError if none)."""
    for d in cfg.drivers:
        if d.name == "stage" and d.worldfile is not None:
            return d.worldfile
    raise StageError(Where(cfg.file, 1), 'a stage driver block with worldfile "..."', "none")


def _device(world: StageWorld, d: DriverBlock, a: Address, model: str) -> str:
    robot = next((r for r in world.spec.robots if r.name == model), None)
    if robot is None:
        kind = "a model that is not a position model" if model in world.fixed or any(
            o.name == model for o in world.spec.objects) else "no such model"
        raise StageError(d.where, f"model {model!r} to be a position model of "
                                  f"{world.spec.source}", kind)
    if a.interface == "ranger":
        rangers = world.rangers.get(model, ())
        role = rangers[a.index].role if a.index < len(rangers) else ""
        if not role:
            raise StageError(d.where, f"ranger:{a.index} among the {len(rangers)} ranger(s) "
                                      f"of model {model!r}", str(a))
        return _RANGER_VIEW[role]
    if a.interface in DIRECT:
        if getattr(robot.devices, a.interface) is None:
            raise StageError(d.where, f"a {a.interface} on model {model!r} in the world "
                                      "(for power: joules or joules_capacity)", str(a))
        return a.interface
    return ""  # an interface Stage has and this server does not


def plan_from_cfg(cfg: PlayerConfig, world: StageWorld, warnings: Warnings) -> ServePlan:
    """Every address of the configuration, bound to a model's device; StageError if a block
    asks for what the world does not have."""
    bound: dict[Address, Binding] = {}

    def bind(b: Binding, where: Where) -> None:
        if b.address in bound:
            raise StageError(where, f"address {b.address} provided once", "a second time")
        bound[b.address] = b

    for d in cfg.drivers:
        if d.name == "stage":
            for a in d.provides:
                if a.interface == "simulation":
                    bind(Binding(a, "", "simulation"), d.where)
                    continue
                if d.model is None:
                    raise StageError(d.where, f'model "NAME" in the stage driver providing {a}',
                                     "none")
                device = _device(world, d, a, d.model)
                if not device:
                    warnings.once(f"iface:{a.interface}",
                                  f"{d.where}: interface {a.interface!r} is not provided here; "
                                  f"{a} skipped")
                    continue
                bind(Binding(a, d.model, device), d.where)
        elif d.name == "rangertolaser":
            if len(d.requires) != 1 or len(d.provides) != 1 or \
                    d.provides[0].interface != "laser" or d.requires[0].interface != "ranger":
                raise StageError(d.where, 'rangertolaser with requires ["ranger:N"] and '
                                          'provides ["laser:M"]',
                                 f"requires {list(map(str, d.requires))}, provides "
                                 f"{list(map(str, d.provides))}")
            src = bound.get(d.requires[0])
            if src is None or src.device not in ("laser_ranger",):
                raise StageError(d.where, f"{d.requires[0]} provided above by a stage block "
                                          "as a laser's ranger",
                                 "nothing" if src is None else src.device)
            bind(Binding(d.provides[0], src.model, "laser"), d.where)
        else:
            warnings.once(f"driver:{d.name}", f"{d.where}: driver {d.name!r} is not provided "
                          "here; skipped (absent: "
                          f"{', '.join(map(str, d.provides)) or 'nothing'})")
    if not bound:
        raise StageError(Where(cfg.file, 1), "a stage driver block that provides devices",
                         "none")
    return ServePlan(worldfile_of(cfg), tuple(bound.values()), tuple(warnings.said))


def plan_from_world(world: StageWorld, base_port: int) -> ServePlan:
    """One port per position model (base_port, base_port + 1, ...): position2d:0, its
    rangers as ranger:N (Stage's order), laser:0 and sonar:0 too, its other devices, and
    simulation:0."""
    out: list[Binding] = []
    for i, r in enumerate(world.spec.robots):
        port = base_port + i

        def add(interface: str, index: int, device: str, model: str = r.name,
                port: int = port) -> None:
            out.append(Binding(Address(port, interface, index), model, device))

        add("position2d", 0, "position2d")
        for k, role in enumerate(world.rangers.get(r.name, ())):
            if role.role:
                add("ranger", k, _RANGER_VIEW[role.role])
        for name in ("laser", "sonar", "blobfinder", "camera", "fiducial", "gripper",
                     "bumper", "power", "ptz"):
            if getattr(r.devices, name) is not None:
                add(name, 0, name)
        add("simulation", 0, "simulation", "")
    return ServePlan(world.spec.source, tuple(out), world.warnings)
