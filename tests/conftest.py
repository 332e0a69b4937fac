"""Shared pytest configuration."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import scheduling

REPO_ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO_ROOT


@pytest.fixture(scope="session")
def worlds_dir() -> Path:
    return REPO_ROOT / "worlds"


# -- sharing the suite between xdist workers: tests/scheduling.py ----------------------------

def pytest_addoption(parser: pytest.Parser) -> None:
    scheduling.add_options(parser)


def pytest_configure(config: pytest.Config) -> None:
    scheduling.configure(config)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    scheduling.order(items)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    if config.getoption("dist") != "loadscope":
        return None
    return scheduling.make_scheduler(config, log)
