"""Scenario files for the consensus allocators (JSON), loaded into frozen dataclasses.

A scenario lists agents and tasks in a fixed order (the order is the index used for
tie-breaking), an optional communication graph (absent = fully connected) and whether tasks
have time windows. Every error names the file, the key, what was expected and what was found.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

# how a task started at time s scores (`scoring.py`): "discount" is
# reward * exp(-discount * (s - ref)); "paper" is the CBGA paper's linear cost,
# reward - ((s - ref) + duration), s being the group's latest arrival for a group task
COSTS = ("discount", "paper")


class ScenarioError(ValueError):
    """A scenario file or dictionary that does not match the format."""

    def __init__(self, file: str, key: str, expected: str, found: object) -> None:
        self.file = file
        self.key = key
        self.expected = expected
        self.found = found
        shown = repr(found)
        if len(shown) > 80:
            shown = shown[:77] + "..."
        super().__init__(f"{file}: {key}: expected {expected}, found {shown}")


@dataclass(frozen=True)
class Agent:
    id: str
    pos: tuple[float, ...]
    speed_mps: float = 1.0
    capabilities: frozenset[str] | None = None  # None = may do every task type
    equipment: frozenset[str] = frozenset()
    availability_s: float = 0.0


@dataclass(frozen=True)
class Task:
    id: str
    pos: tuple[float, ...]
    type: str = "task"
    reward: float = 100.0
    discount: float = 0.0
    start_s: float = 0.0
    end_s: float = math.inf  # latest start time
    duration_s: float = 0.0
    agents_required: int = 1
    equipment: frozenset[str] = frozenset()
    prerequisites: tuple[str, ...] = ()
    quit_after: float | None = None  # consensus rounds (sync) or agent iterations (async)
    team_reward: float = 0.0


@dataclass(frozen=True)
class CommGraph:
    directed: bool = False
    edges: tuple[tuple[str, str], ...] | None = None  # None = fully connected


@dataclass(frozen=True)
class Scenario:
    name: str
    agents: tuple[Agent, ...]
    tasks: tuple[Task, ...]
    time_windows: bool = True
    max_depth: int | None = None  # bundle limit; None = number of tasks
    comm_graph: CommGraph = field(default_factory=CommGraph)
    cost: str = "discount"  # one of COSTS: how a task's score falls with its start

    @property
    def bundle_limit(self) -> int:
        return len(self.tasks) if self.max_depth is None else self.max_depth

    def neighbours(self) -> tuple[tuple[int, ...], ...]:
        """For each agent index, the sorted indices of the agents it receives from."""
        n = len(self.agents)
        if self.comm_graph.edges is None:
            return tuple(tuple(k for k in range(n) if k != i) for i in range(n))
        index = {a.id: i for i, a in enumerate(self.agents)}
        incoming: list[set[int]] = [set() for _ in range(n)]
        for src, dst in self.comm_graph.edges:
            a, b = index[src], index[dst]
            if a == b:
                continue
            incoming[b].add(a)
            if not self.comm_graph.directed:
                incoming[a].add(b)
        return tuple(tuple(sorted(s)) for s in incoming)

    def with_tasks(self, tasks: Sequence[Task]) -> Scenario:
        return replace(self, tasks=tuple(self.tasks) + tuple(tasks))

    def without_agent_edges(self, agent_id: str) -> Scenario:
        """The same scenario with every link to or from `agent_id` cut."""
        n = len(self.agents)
        if self.comm_graph.edges is None:
            ids = [a.id for a in self.agents]
            edges = tuple(
                (ids[i], ids[k]) for i in range(n) for k in range(i + 1, n)
                if agent_id not in (ids[i], ids[k])
            )
            return replace(self, comm_graph=CommGraph(False, edges))
        edges = tuple(e for e in self.comm_graph.edges if agent_id not in e)
        return replace(self, comm_graph=CommGraph(self.comm_graph.directed, edges))


# ----------------------------------------------------------------------------- parsing


class _Reader:
    def __init__(self, file: str) -> None:
        self.file = file

    def fail(self, key: str, expected: str, found: object) -> ScenarioError:
        return ScenarioError(self.file, key, expected, found)

    def obj(self, data: object, key: str) -> Mapping[str, Any]:
        if not isinstance(data, Mapping):
            raise self.fail(key, "an object", data)
        return data

    def number(self, data: Mapping[str, Any], key: str, path: str, default: float | None = None,
               minimum: float | None = None, allow_null: bool = False) -> float:
        if key not in data:
            if default is None:
                raise self.fail(f"{path}.{key}", "a number (required)", "nothing")
            return default
        value = data[key]
        if value is None and allow_null:
            return math.inf
        if isinstance(value, bool) or not isinstance(value, int | float) or math.isnan(value):
            raise self.fail(f"{path}.{key}", "a number", value)
        if minimum is not None and value < minimum:
            raise self.fail(f"{path}.{key}", f"a number >= {minimum}", value)
        return float(value)

    def string(self, data: Mapping[str, Any], key: str, path: str,
               default: str | None = None) -> str:
        if key not in data:
            if default is None:
                raise self.fail(f"{path}.{key}", "a string (required)", "nothing")
            return default
        value = data[key]
        if not isinstance(value, str) or not value:
            raise self.fail(f"{path}.{key}", "a non-empty string", value)
        return value

    def strings(self, data: Mapping[str, Any], key: str, path: str) -> tuple[str, ...] | None:
        if key not in data or data[key] is None:
            return None
        value = data[key]
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise self.fail(f"{path}.{key}", "a list of strings", value)
        return tuple(value)

    def position(self, data: Mapping[str, Any], path: str) -> tuple[float, ...]:
        if "pos" not in data:
            raise self.fail(f"{path}.pos", "a list of 2 or 3 numbers (required)", "nothing")
        value = data["pos"]
        if (not isinstance(value, list) or len(value) not in (2, 3)
                or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)):
            raise self.fail(f"{path}.pos", "a list of 2 or 3 numbers", value)
        return tuple(float(v) for v in value)


def parse_scenario(data: object, source: str = "<scenario>") -> Scenario:
    """Build a Scenario from decoded JSON, raising ScenarioError on the first problem."""
    r = _Reader(source)
    top = r.obj(data, "(top level)")
    name = r.string(top, "name", "scenario", default=Path(source).stem or "scenario")
    time_windows = top.get("time_windows", True)
    if not isinstance(time_windows, bool):
        raise r.fail("time_windows", "true or false", time_windows)
    max_depth = top.get("max_depth")
    if max_depth is not None and (isinstance(max_depth, bool) or not isinstance(max_depth, int)
                                  or max_depth < 1):
        raise r.fail("max_depth", "a positive integer or null", max_depth)

    cost = top.get("cost", "discount")
    if cost not in COSTS:
        raise r.fail("cost", " or ".join(repr(c) for c in COSTS), cost)

    raw_agents = top.get("agents")
    if not isinstance(raw_agents, list) or not raw_agents:
        raise r.fail("agents", "a non-empty list of agent objects", raw_agents)
    agents: list[Agent] = []
    for n, raw in enumerate(raw_agents):
        path = f"agents[{n}]"
        a = r.obj(raw, path)
        caps = r.strings(a, "capabilities", path)
        agents.append(Agent(
            id=r.string(a, "id", path),
            pos=r.position(a, path),
            speed_mps=r.number(a, "speed", path, default=1.0),
            capabilities=None if caps is None else frozenset(caps),
            equipment=frozenset(r.strings(a, "equipment", path) or ()),
            availability_s=r.number(a, "availability", path, default=0.0, minimum=0.0),
        ))
        if agents[-1].speed_mps <= 0:
            raise r.fail(f"{path}.speed", "a positive number", a.get("speed"))
    _check_unique(r, "agents", [a.id for a in agents])

    raw_tasks = top.get("tasks")
    if not isinstance(raw_tasks, list):
        raise r.fail("tasks", "a list of task objects", raw_tasks)
    tasks: list[Task] = []
    for n, raw in enumerate(raw_tasks):
        path = f"tasks[{n}]"
        t = r.obj(raw, path)
        start = r.number(t, "start", path, default=0.0)
        end = r.number(t, "end", path, default=math.inf, allow_null=True)
        if end < start:
            raise r.fail(f"{path}.end", f"a latest start >= start ({start})", t.get("end"))
        required = t.get("agents_required", 1)
        if isinstance(required, bool) or not isinstance(required, int) or required < 1:
            raise r.fail(f"{path}.agents_required", "a positive integer", required)
        quit_after = t.get("quit_after")
        if quit_after is not None and (isinstance(quit_after, bool)
                                       or not isinstance(quit_after, int | float)
                                       or quit_after < 0):
            raise r.fail(f"{path}.quit_after", "a non-negative number or null", quit_after)
        tasks.append(Task(
            id=r.string(t, "id", path),
            pos=r.position(t, path),
            type=r.string(t, "type", path, default="task"),
            reward=r.number(t, "reward", path, default=100.0),
            discount=r.number(t, "discount", path, default=0.0, minimum=0.0),
            start_s=start,
            end_s=end,
            duration_s=r.number(t, "duration", path, default=0.0, minimum=0.0),
            agents_required=required,
            equipment=frozenset(r.strings(t, "equipment", path) or ()),
            prerequisites=r.strings(t, "prerequisites", path) or (),
            quit_after=None if quit_after is None else float(quit_after),
            team_reward=r.number(t, "team_reward", path, default=0.0, minimum=0.0),
        ))
    _check_unique(r, "tasks", [t.id for t in tasks])
    task_ids = {t.id for t in tasks}
    for n, task in enumerate(tasks):
        for p in task.prerequisites:
            if p not in task_ids or p == task.id:
                raise r.fail(f"tasks[{n}].prerequisites", "ids of other tasks", p)
    dims = {len(a.pos) for a in agents} | {len(t.pos) for t in tasks}
    if len(dims) > 1:
        raise r.fail("pos", "the same dimension (2 or 3) everywhere", sorted(dims))

    graph = _parse_graph(r, top.get("comm_graph"), {a.id for a in agents})
    return Scenario(name=name, agents=tuple(agents), tasks=tuple(tasks),
                    time_windows=time_windows, max_depth=max_depth, comm_graph=graph,
                    cost=cost)


def _parse_graph(r: _Reader, raw: object, ids: set[str]) -> CommGraph:
    """The scenario's communication graph (everyone hears everyone when absent)."""
    if raw is None:
        return CommGraph()
    g = r.obj(raw, "comm_graph")
    directed = g.get("directed", False)
    if not isinstance(directed, bool):
        raise r.fail("comm_graph.directed", "true or false", directed)
    raw_edges = g.get("edges")
    if not isinstance(raw_edges, list):
        raise r.fail("comm_graph.edges", "a list of [agent_id, agent_id] pairs", raw_edges)
    edges: list[tuple[str, str]] = []
    for n, e in enumerate(raw_edges):
        if (not isinstance(e, list) or len(e) != 2
                or not all(isinstance(x, str) and x in ids for x in e)):
            raise r.fail(f"comm_graph.edges[{n}]", "a pair of known agent ids", e)
        edges.append((e[0], e[1]))
    return CommGraph(directed, tuple(edges))


def _check_unique(r: _Reader, key: str, ids: list[str]) -> None:
    seen: set[str] = set()
    for n, i in enumerate(ids):
        if i in seen:
            raise r.fail(f"{key}[{n}].id", "a unique id", i)
        seen.add(i)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ScenarioError(str(p), "(file)", "a readable file", exc.strerror or str(exc)) from exc
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ScenarioError(str(p), f"(line {exc.lineno}, column {exc.colno})", "valid JSON",
                            exc.msg) from exc
    return parse_scenario(data, str(p))


def scenario_to_dict(s: Scenario) -> dict[str, Any]:
    """The JSON form of a scenario (round-trips through parse_scenario)."""
    def num(x: float) -> float | int | None:
        if math.isinf(x):
            return None
        return int(x) if float(x).is_integer() else round(x, 6)

    out: dict[str, Any] = {"name": s.name, "time_windows": s.time_windows,
                           "max_depth": s.max_depth}
    if s.cost != "discount":
        out["cost"] = s.cost
    if s.comm_graph.edges is not None:
        out["comm_graph"] = {"directed": s.comm_graph.directed,
                             "edges": [list(e) for e in s.comm_graph.edges]}
    out["agents"] = [
        {"id": a.id, "pos": [num(v) for v in a.pos], "speed": num(a.speed_mps),
         **({} if a.capabilities is None else {"capabilities": sorted(a.capabilities)}),
         "equipment": sorted(a.equipment), "availability": num(a.availability_s)}
        for a in s.agents
    ]
    out["tasks"] = [
        {"id": t.id, "pos": [num(v) for v in t.pos], "type": t.type, "reward": num(t.reward),
         "discount": num(t.discount), "start": num(t.start_s), "end": num(t.end_s),
         "duration": num(t.duration_s), "agents_required": t.agents_required,
         "equipment": sorted(t.equipment), "prerequisites": list(t.prerequisites),
         "quit_after": None if t.quit_after is None else num(t.quit_after),
         "team_reward": num(t.team_reward)}
        for t in s.tasks
    ]
    return out
