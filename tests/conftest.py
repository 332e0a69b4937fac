"""Shared pytest configuration."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

REPO_ROOT = Path(__file__).resolve().parent.parent

# property tests draw the same examples on every run, so that a run of the suite repeats;
# HYPOTHESIS_PROFILE=explore draws new ones (to look for failing cases on purpose)
settings.register_profile("repeatable", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))


@pytest.fixture(scope="session")
def repo_root() -> Path:
    return REPO_ROOT


@pytest.fixture(scope="session")
def worlds_dir() -> Path:
    return REPO_ROOT / "worlds"


LONG_FIRST = (
    "test_viz_live.py",
    "test_soak.py",
    "test_plugin_package.py",
    "test_allocators_run.py",
    "test_readme.py",
    "test_experiments_boxpush_variants.py",
    "test_experiments_compare_dask.py",
    "test_experiments_compare.py",
    "test_allocators_groups.py",
)
"""The modules that take longest (docs/internals.md lists their tests), handed to the
pytest-xdist workers first, the rest after them in their usual order: a long module started
last would leave the other workers idle at the end of the suite."""


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    rank = {name: i for i, name in enumerate(LONG_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(LONG_FIRST)))  # stable
