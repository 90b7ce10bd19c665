"""The one visibility rule of fiducial sensors (collab_tools.core.visibility), shared by the
coalition core's geometric sensing and the bridge's simulated fiducial."""
import math

import pytest

from collab_tools.core.visibility import (
    ANGLE_TOLERANCE_RAD, RANGE_TOLERANCE_M, Box, bearing, boxes_above, in_field_of_view, line_of_sight_clear,
    point_in_box, segment_meets_box, segment_meets_disc, wrap_angle,
)


def offset(distance, angle):
    return distance * math.cos(angle), distance * math.sin(angle)


@pytest.mark.parametrize('heading_deg, fov_deg', [(0.0, 180.0), (60.0, 120.0), (-135.0, 90.0), (170.0, 30.0)])
def test_the_field_of_view_edges_are_included_up_to_the_tolerance(heading_deg, fov_deg):
    heading, half = math.radians(heading_deg), math.radians(fov_deg) / 2.0
    for side in (1.0, -1.0):
        assert in_field_of_view(*offset(2.0, heading + side * half), heading, fov_deg, 4.0)          # exactly on it
        assert in_field_of_view(*offset(2.0, heading + side * (half + 0.5 * ANGLE_TOLERANCE_RAD)), heading,
                                fov_deg, 4.0)
        assert not in_field_of_view(*offset(2.0, heading + side * (half + 1e-4)), heading, fov_deg, 4.0)


def test_the_range_edge_is_included_and_the_full_circle_sees_behind():
    assert in_field_of_view(3.0, 0.0, 0.0, 90.0, 3.0)
    assert in_field_of_view(3.0 + 0.5 * RANGE_TOLERANCE_M, 0.0, 0.0, 90.0, 3.0)
    assert not in_field_of_view(3.001, 0.0, 0.0, 90.0, 3.0)
    assert in_field_of_view(-1.0, 0.0, 0.0, 360.0, 3.0)        # behind, full circle
    assert not in_field_of_view(-1.0, 0.0, 0.0, 359.0, 3.0)
    assert in_field_of_view(-1e6, 0.0, 0.0, 360.0, math.inf)


def test_bearings_wrap_to_minus_pi_pi():
    assert wrap_angle(math.pi) == pytest.approx(-math.pi)
    assert bearing(0.0, 1.0, math.radians(170.0)) == pytest.approx(math.radians(-80.0))
    assert bearing(-1.0, 0.0, math.radians(-179.0)) == pytest.approx(math.radians(-1.0))


def test_a_wall_across_the_line_of_sight_blocks_and_one_beside_it_does_not():
    wall = Box((1.0, 0.0), (0.1, 1.0))
    beside = Box((1.0, 0.6), (1.0, 0.1))
    segment = ((0.0, 0.0), (2.0, 0.0))
    assert not line_of_sight_clear(segment, [wall])
    assert line_of_sight_clear(segment, [beside])
    assert line_of_sight_clear(((0.0, 0.0), (0.9, 0.0)), [wall])     # stops short of the wall
    assert line_of_sight_clear(segment, [])


def test_a_rotated_box_blocks_only_where_it_stands():
    diamond = Box((1.0, 0.0), (0.2, 0.2), yaw=math.pi / 4)         # corners at x = 1 +- 0.1414, y = +-0.1414
    assert segment_meets_box((1.0, -1.0), (1.0, 1.0), diamond)
    assert not segment_meets_box((0.0, 0.15), (2.0, 0.15), diamond)
    assert segment_meets_box((0.0, 0.13), (2.0, 0.13), diamond)


def test_touching_a_corner_blocks_and_passing_by_the_grazing_tolerance_does_not():
    # Closed boxes: a line of sight through a corner (distance 0) is blocked in the core; the bridge
    # agrees only beyond GRAZING_TOLERANCE_M (module docstring).
    box = Box((1.0, 1.0), (1.0, 1.0))                                # corner at (0.5, 0.5)
    assert not line_of_sight_clear(((0.0, 0.0), (1.0, 1.0)), [box])
    assert not line_of_sight_clear(((0.0, 1.0), (1.0, 0.0)), [box])  # touches the corner only
    assert line_of_sight_clear(((0.0, 1.0 - 0.002), (1.0 - 0.002, 0.0)), [box])


def test_points_discs_and_the_boxes_a_sensor_cannot_see_over():
    box = Box((0.0, 0.0), (2.0, 1.0), height=0.1)
    assert point_in_box((1.2, 0.0), box, margin=0.23) and not point_in_box((1.3, 0.0), box, margin=0.23)
    assert point_in_box((0.0, 0.0), box)
    assert boxes_above([box, Box((0, 0), (1, 1), height=0.3)], 0.12) == [Box((0, 0), (1, 1), height=0.3)]
    assert segment_meets_disc((0.0, 0.0), (2.0, 0.0), (1.0, 0.23), 0.23)
    assert not segment_meets_disc((0.0, 0.0), (2.0, 0.0), (1.0, 0.24), 0.23)
    assert not segment_meets_disc((0.0, 0.0), (2.0, 0.0), (2.5, 0.0), 0.23)
