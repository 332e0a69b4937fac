"""The team clock tables a host process's robots share (`behaviors.murdoch_link.SharedTables`)."""

from __future__ import annotations

import threading

import pytest

from behaviors.murdoch_link import SharedTables
from player_server.protocol.team_clock import decode_table, encode_table


def test_the_same_bytes_give_every_robot_the_same_read_only_table() -> None:
    tables = SharedTables()
    raw = encode_table({"p1/1": 3, "runner/1": 7})
    seen: list[object] = []

    def robot() -> None:
        for _ in range(200):
            seen.append(tables.decode(raw))

    threads = [threading.Thread(target=robot) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=30)
    assert len(seen) == 1600
    first = seen[0]
    assert all(s is first for s in seen)
    assert dict(first) == decode_table(raw) == {"p1/1": 3, "runner/1": 7}
    with pytest.raises(TypeError):
        first["p1/1"] = 4


def test_new_bytes_are_decoded_and_a_few_recent_tables_kept() -> None:
    tables = SharedTables()
    raws = [encode_table({"p1/1": n}) for n in range(SharedTables.KEEP + 1)]
    got = [tables.decode(r) for r in raws]
    assert [dict(g) for g in got] == [{"p1/1": n} for n in range(SharedTables.KEEP + 1)]
    assert tables.decode(raws[-1]) is got[-1]  # recent: kept
    assert tables.decode(raws[1]) is got[1]
    assert tables.decode(raws[0]) is not got[0]  # the oldest was let go: decoded again
    assert dict(tables.decode(raws[0])) == {"p1/1": 0}
    assert dict(tables.decode(b"")) == {}


def test_a_table_that_does_not_decode_is_refused_and_not_kept() -> None:
    tables = SharedTables()
    for bad in (b"{", b'{"c": {"p1/1": -1}}', b'{"c": {"p1/1": NaN}}', b"[1]"):
        with pytest.raises(ValueError):
            tables.decode(bad)
        with pytest.raises(ValueError):
            tables.decode(bad)
