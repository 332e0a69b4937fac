"""Contact between a robot's body and a charging model's footprint (pure geometry)."""

from __future__ import annotations

import math

from player_server.sim.contact import MARGIN_M, rects_touch

DOCK = (0.0, 0.0, 0.15, 0.3, 0.0)  # 0.3 x 0.6 m, at the origin


def test_bodies_touch_when_they_overlap_or_come_within_the_margin() -> None:
    # a 0.44 m long body facing the dock's +x face, its nose `gap` metres away
    for gap, touching in ((-0.01, True), (0.0, True), (MARGIN_M - 0.005, True),
                          (MARGIN_M + 0.005, False), (1.0, False)):
        body = (0.15 + gap + 0.22, 0.0, 0.22, 0.19, math.pi)
        assert rects_touch(body, DOCK) is touching, gap
    # beside the dock's end (y) and diagonally off its corner
    assert rects_touch((0.0, 0.3 + 0.19 + 0.04, 0.22, 0.19, 0.0), DOCK)
    assert not rects_touch((0.0, 0.3 + 0.19 + 0.06, 0.22, 0.19, 0.0), DOCK)
    assert not rects_touch((0.6, 0.75, 0.22, 0.19, 0.0), DOCK)


def test_turned_rectangles_use_their_own_axes() -> None:
    # a body turned 45 degrees whose corner points at the dock's face: its corner reaches
    # 0.22 * cos 45 + 0.19 * sin 45 = 0.290 m from its centre along x
    reach = 0.22 * math.cos(math.pi / 4) + 0.19 * math.sin(math.pi / 4)
    assert rects_touch((0.15 + reach + 0.04, 0.0, 0.22, 0.19, math.pi / 4), DOCK)
    assert not rects_touch((0.15 + reach + 0.06, 0.0, 0.22, 0.19, math.pi / 4), DOCK)
    # the dock turned 90 degrees is 0.6 m long in x: a body 0.4 m off its centre touches it
    turned = (0.0, 0.0, 0.15, 0.3, math.pi / 2)
    assert rects_touch((0.3 + 0.22 + 0.01, 0.0, 0.22, 0.19, 0.0), turned)
    assert not rects_touch((0.3 + 0.22 + 0.01, 0.0, 0.22, 0.19, 0.0), DOCK)


def test_an_outline_touches_where_its_own_edges_reach() -> None:
    from player_server.sim.contact import corners, polygon_touches

    # a wedge body pointing at the dock's +x face: its tip is at the centre's height, its
    # back corners 0.4 m behind and 0.2 m to either side
    for gap, touching in ((0.0, True), (MARGIN_M - 0.005, True), (MARGIN_M + 0.005, False)):
        tip = 0.15 + gap
        wedge = [(tip, 0.0), (tip + 0.4, -0.2), (tip + 0.4, 0.2)]
        assert polygon_touches(wedge, DOCK) is touching, gap
    # beside the dock's corner: its box would touch, the wedge's slanted side does not
    wedge = [(0.56, 0.16), (0.56, 0.56), (0.16, 0.56)]  # the half away from the dock
    assert rects_touch((0.36, 0.36, 0.2, 0.2, 0.0), DOCK)
    assert not polygon_touches(wedge, DOCK)
    # a rectangle's corners as a polygon agree with the rectangle test
    for body in ((0.5, 0.1, 0.22, 0.19, 0.3), (0.2, 0.8, 0.22, 0.19, 1.0),
                 (0.45, 0.0, 0.22, 0.19, math.pi / 4)):
        assert polygon_touches(corners(body), DOCK) is rects_touch(body, DOCK), body
