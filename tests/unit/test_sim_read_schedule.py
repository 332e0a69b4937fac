"""Which sensors a tick's sensing pass computes (`player_server.sim.read_schedule`)."""

from __future__ import annotations

from player_server.sim.read_schedule import ReadSchedule


def test_a_sensor_read_every_tick_is_expected_from_its_second_read_on() -> None:
    s: ReadSchedule[str] = ReadSchedule()
    s.note("sonar", 0)
    assert s.expected(1) == ()  # read once: nothing to go by yet
    s.note("sonar", 1)
    assert s.expected(2) == ("sonar",)
    s.note("sonar", 2)
    s.note("sonar", 2)  # read twice in a tick: still every tick
    assert s.expected(3) == ("sonar",)


def test_a_sensor_read_every_k_ticks_is_expected_on_its_turn_only() -> None:
    s: ReadSchedule[str] = ReadSchedule()
    expected = {}
    for tick in range(0, 21):
        expected[tick] = s.expected(tick)
        s.note("sonar", tick)
        if tick % 5 == 0:
            s.note("laser", tick)
    # the laser was read at 0 and 5: due at 10, 15 and 20, not in between
    assert [t for t, e in expected.items() if "laser" in e] == [10, 15, 20]
    assert all("sonar" in e for t, e in expected.items() if t >= 2)


def test_what_is_read_in_the_tick_joins_what_was_expected() -> None:
    s: ReadSchedule[tuple[int, str]] = ReadSchedule()
    for tick in (0, 1):
        s.note((1, "sonar"), tick)
    s.note((0, "laser"), 2)  # never read before: not due, but read now
    assert s.expected(2) == ((0, "laser"), (1, "sonar"))
    assert s.known() == {(0, "laser"), (1, "sonar")}


def test_the_same_tuple_while_the_expected_sensors_do_not_change() -> None:
    s: ReadSchedule[str] = ReadSchedule()
    for tick in range(4):
        s.note("a", tick)
        s.note("b", tick)
    first = s.expected(4)
    assert first == ("a", "b") and s.expected(4) is first


def test_a_sensor_no_longer_read_stops_being_expected() -> None:
    s: ReadSchedule[str] = ReadSchedule()
    for tick in range(3):
        s.note("sonar", tick)
    s.note("other", 3)  # the sonar is not read in tick 3
    assert s.expected(4) == ()
