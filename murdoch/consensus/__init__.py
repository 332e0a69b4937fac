"""Consensus allocators: CBBA and CBGA on scenario files, run in synchronous rounds or
asynchronously over the MURDOCH publish/subscribe bus."""

from murdoch.consensus.cbga import CbgaOptions
from murdoch.consensus.scenario import (
    Agent,
    CommGraph,
    Scenario,
    ScenarioError,
    Task,
    load_scenario,
    parse_scenario,
    scenario_to_dict,
)
from murdoch.consensus.sga import sequential_greedy
from murdoch.consensus.sync_runner import AllocationResult, SyncRunner, allocate

__all__ = [
    "Agent",
    "AllocationResult",
    "CbgaOptions",
    "CommGraph",
    "Scenario",
    "ScenarioError",
    "SyncRunner",
    "Task",
    "allocate",
    "load_scenario",
    "parse_scenario",
    "scenario_to_dict",
    "sequential_greedy",
]
