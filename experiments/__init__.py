"""Composition root: the `murdoch` command and the experiment runner that wires server,
robot processes and allocators together."""
