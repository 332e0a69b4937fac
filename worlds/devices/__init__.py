"""Device kinds beyond the built-ins, one module each, found by `worlds.device_kinds`.

A module here declares its kind's parameters (a frozen dataclass decorated with
`worlds.device_kinds.declare_device`); nothing lists it. See docs/internals.md, "Recipe: a new
device kind".
"""
