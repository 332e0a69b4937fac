"""Scenario files: loading, clear errors, round trips, the shipped examples."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from murdoch.consensus.scenario import (
    ScenarioError,
    load_scenario,
    parse_scenario,
    scenario_to_dict,
)

EXAMPLE = {
    "name": "s1", "time_windows": True, "max_depth": 4,
    "comm_graph": {"directed": False, "edges": [["a1", "a2"]]},
    "agents": [{"id": "a1", "pos": [0, 0], "speed": 1.0, "capabilities": ["track"],
                "equipment": ["camera"], "availability": 0},
               {"id": "a2", "pos": [3, 4]}],
    "tasks": [{"id": "t1", "pos": [1, 1], "type": "track", "reward": 100, "discount": 0.05,
               "start": 0, "end": 20, "duration": 3, "agents_required": 1,
               "equipment": ["camera"], "prerequisites": [], "quit_after": 30,
               "team_reward": 0}],
}


def test_example_of_the_format_loads() -> None:
    s = parse_scenario(EXAMPLE)
    assert s.name == "s1" and s.max_depth == 4 and s.time_windows
    assert s.agents[0].capabilities == frozenset({"track"})
    assert s.agents[1].capabilities is None  # absent: may do everything
    assert s.tasks[0].end_s == 20 and s.tasks[0].quit_after == 30
    assert s.neighbours() == ((1,), (0,))


def test_absent_graph_is_fully_connected() -> None:
    data = dict(EXAMPLE)
    del data["comm_graph"]
    assert parse_scenario(data).neighbours() == ((1,), (0,))


def test_directed_graph_only_carries_one_way() -> None:
    data = {**EXAMPLE, "comm_graph": {"directed": True, "edges": [["a1", "a2"]]}}
    assert parse_scenario(data).neighbours() == ((), (0,))


@pytest.mark.parametrize(("mutate", "key", "expected"), [
    (lambda d: d["agents"][1].pop("pos"), "agents[1].pos", "2 or 3 numbers"),
    (lambda d: d["tasks"][0].update(reward="lots"), "tasks[0].reward", "a number"),
    (lambda d: d["tasks"][0].update(end=-1), "tasks[0].end", "latest start"),
    (lambda d: d["tasks"][0].update(agents_required=0), "tasks[0].agents_required",
     "positive integer"),
    (lambda d: d["tasks"][0].update(prerequisites=["nope"]), "tasks[0].prerequisites",
     "ids of other tasks"),
    (lambda d: d["comm_graph"].update(edges=[["a1", "zz"]]), "comm_graph.edges[0]",
     "known agent ids"),
    (lambda d: d["agents"].append({"id": "a1", "pos": [0, 0]}), "agents[2].id", "unique"),
    (lambda d: d.update(max_depth=0), "max_depth", "positive integer"),
])
def test_errors_name_file_key_expected_found(mutate, key: str, expected: str) -> None:
    data = json.loads(json.dumps(EXAMPLE))
    mutate(data)
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data, "bad.json")
    err = info.value
    assert err.file == "bad.json" and err.key == key
    assert expected in err.expected
    assert "bad.json" in str(err) and key in str(err) and "found" in str(err)


def test_bad_json_reports_line(tmp_path: Path) -> None:
    p = tmp_path / "broken.json"
    p.write_text('{"agents": [\n  oops ]}')
    with pytest.raises(ScenarioError) as info:
        load_scenario(p)
    assert "line 2" in info.value.key and str(p) in str(info.value)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="readable file"):
        load_scenario(tmp_path / "nothing.json")


def test_round_trip() -> None:
    s = parse_scenario(EXAMPLE)
    again = parse_scenario(json.loads(json.dumps(scenario_to_dict(s))))
    assert again == s


def test_open_window_round_trips_as_null() -> None:
    data = json.loads(json.dumps(EXAMPLE))
    data["tasks"][0]["end"] = None
    s = parse_scenario(data)
    assert math.isinf(s.tasks[0].end_s)
    assert scenario_to_dict(s)["tasks"][0]["end"] is None


def test_shipped_examples_load(worlds_dir: Path) -> None:
    files = sorted((worlds_dir / "scenarios").glob("consensus-*.json"))
    assert len(files) >= 3
    for f in files:
        s = load_scenario(f)
        assert s.agents and s.tasks
