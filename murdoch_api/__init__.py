"""The one module a plugin imports: the stable names for allocators, task kinds and
experiments (docs/extending.md).

Allocators (`murdoch.plugin`): `CentralAllocator` (one class, one decision hook), the views
a decision sees (`TaskView`, `RobotView`, `WorldView`), `Allocator` and its hooks for a
distributed allocator, `check_allocator`.

Experiments and task kinds (`experiments.plugin`): `ExperimentBase` / `Experiment`,
`Option`, `Supports`, `RunOptions`, `PlannedTask`, `TaskKind`, `check_experiment`,
`check_task_kind`, what a referee sees (`Referee`, `RunHandle`), and `check_referee` with its
in-memory `ScriptedRun`.

Composing the robot-side behaviour of a task kind: `TaskPlan`, `Stage`, `Layer`,
`ServoToLocation`, `avoid_layers`, `signal`, `elapsed`, `elapsed_progress`,
`WeightedMetric`, `negative_distance`, `battery_fraction`, `number`, `RobotProfile`.

Every name listed in `__all__` is stable: kept compatible across minor versions. Anything
imported from elsewhere in the project may change without notice.
"""

from __future__ import annotations

from behaviors.arbiter import Layer
from behaviors.basis import ServoToLocation
from behaviors.metrics import WeightedMetric, battery_fraction, negative_distance
from behaviors.params import ParamError, number
from behaviors.plan_parts import avoid_layers, elapsed_progress
from behaviors.profile import RobotProfile
from behaviors.task import Stage, TaskPlan, elapsed, signal
from behaviors.task_kinds import check_task_kind
from experiments.plugin import (
    Experiment,
    ExperimentBase,
    Fault,
    NoReferee,
    Option,
    OptionError,
    Place,
    PlannedTask,
    Referee,
    RunHandle,
    RunOptions,
    Supports,
    TaskKind,
    TaskSite,
    Verdict,
    default_place,
    duration,
    fraction,
    robot_at_time,
)
from experiments.plugin_check import check_experiment
from experiments.referee_check import ScriptedRun, check_referee
from murdoch.plugin import (
    Allocator,
    Assignment,
    CentralAllocator,
    ContractError,
    PluginError,
    RobotHooks,
    RobotView,
    TaskView,
    UserHooks,
    WorldView,
    central_allocator,
    check_allocator,
)

__all__ = [
    "Allocator", "Assignment", "CentralAllocator", "ContractError", "Experiment",
    "ExperimentBase", "Fault", "Layer", "NoReferee", "Option", "OptionError", "ParamError",
    "Place", "PlannedTask", "PluginError", "Referee", "RobotHooks", "RobotProfile",
    "RobotView", "RunHandle", "RunOptions", "ScriptedRun", "ServoToLocation", "Stage",
    "Supports",
    "TaskKind", "TaskPlan", "TaskSite", "TaskView", "UserHooks", "Verdict", "WeightedMetric",
    "WorldView", "avoid_layers", "battery_fraction", "central_allocator", "check_allocator",
    "check_experiment", "check_referee", "check_task_kind", "default_place", "duration", "elapsed",
    "elapsed_progress", "fraction", "negative_distance", "number", "robot_at_time", "signal",
]
