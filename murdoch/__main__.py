"""``python -m murdoch``: the ``murdoch`` command (listen, announce, allocate, sweep, run, report).

The command group is the experiments package's (it also holds `run` and `report`); this module
is the only part of ``murdoch`` allowed to reach it (see the import contracts in
pyproject.toml), and nothing in ``murdoch`` imports this module.
"""

from __future__ import annotations


def main() -> None:
    from experiments.cli import main as murdoch_command

    murdoch_command(prog_name="murdoch")


if __name__ == "__main__":
    main()
