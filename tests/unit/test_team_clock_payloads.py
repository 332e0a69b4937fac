"""The team clock's payloads: declarations and count tables, and what they refuse."""

from __future__ import annotations

import pytest

from player_server.protocol.team_clock import (
    Declaration,
    check_key,
    decode_table,
    encode_table,
)


def test_tables_and_declarations_round_trip() -> None:
    table = {"p2/0": 9, "p1/0": 12, "user/0": 31}
    assert decode_table(encode_table(table)) == table
    assert Declaration.decode(Declaration("p1/3", 7).encode()) == Declaration("p1/3", 7)


@pytest.mark.parametrize("payload", [
    b'{"c":{"p1 /0":1}}', b'{"c":{"p1/0":-1}}', b'{"c":{"p1/0":1.5}}', b'{"c":{"p1/0":NaN}}',
    b'{"c":[]}', b'{"c":{}, "x":1}', b"[1]", b"\xff",
])
def test_bad_tables_are_refused(payload: bytes) -> None:
    with pytest.raises(ValueError):
        decode_table(payload)


def test_a_key_checked_once_is_still_refused_in_any_other_form() -> None:
    assert check_key("p7/0") == "p7/0"
    assert check_key("p7/0") == "p7/0"  # the second time from the set of known keys
    for bad in (["p7/0"], b"p7/0", None, "p7 /0", "p7"):
        with pytest.raises(ValueError):
            check_key(bad)
    with pytest.raises(ValueError):
        Declaration.decode(b'{"s":["p7/0"],"n":1}')
