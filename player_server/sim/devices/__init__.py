"""The device models of the simulator, one module per kind, and their registry.

`MODEL_CLASSES` is every model class of the modules of this package (a class with the
`base.DeviceModel` interface: non-empty `kinds`), found here without being listed, in the
order the world builds and advances them (`order`, then module name); `DEVICE_MODELS` maps
each device name of the world file to its model. A new device kind is one module here; see
docs/internals.md for the rest of the recipe.
"""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path

from player_server.sim.devices.base import DeviceModel


def _model_classes() -> tuple[type[DeviceModel], ...]:
    found: list[type[DeviceModel]] = []
    for mod in sorted(m.name for m in pkgutil.iter_modules([str(Path(__file__).parent)])):
        module = importlib.import_module(f"{__package__}.{mod}")
        for obj in vars(module).values():
            kinds: object = getattr(obj, "kinds", None)
            if (isinstance(obj, type) and obj.__module__ == module.__name__ and kinds
                    and hasattr(obj, "advance")):
                found.append(obj)
    return tuple(sorted(found, key=lambda cls: (cls.order, cls.__module__)))


MODEL_CLASSES: tuple[type[DeviceModel], ...] = _model_classes()
DEVICE_MODELS: dict[str, type[DeviceModel]] = {
    kind: cls for cls in MODEL_CLASSES for kind in cls.kinds
}

__all__ = ["DEVICE_MODELS", "MODEL_CLASSES", "DeviceModel"]
