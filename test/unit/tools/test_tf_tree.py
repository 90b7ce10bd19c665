"""TfTree: composing transforms through the tree as tf2's lookupTransform does."""
import math

import pytest

from collab_tools.core.tf_tree import Pose, TfLookupError, TfTree


def yaw(angle):
    return (0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2))


def close(a, b, tol=1e-9):
    return all(abs(x - y) < tol for x, y in zip(a, b))


def same_rotation(a, b, tol=1e-9):
    # q and -q are the same rotation
    return close(a, b, tol) or close(a, tuple(-v for v in b), tol)


@pytest.fixture
def tree():
    t = TfTree()
    t.add('world', 'robot/base_link', Pose((1.0, 2.0, 0.1), yaw(math.pi / 2)))
    t.add('robot/base_link', 'robot/laser_link', Pose((0.2, 0.0, 0.1)))
    t.add('world', 'camera', Pose((0.0, 0.0, 5.0), yaw(math.pi)))
    return t


def test_lookup_composes_down_the_tree(tree):
    pose = tree.lookup('world', 'robot/laser_link')
    # 0.2 m forward of a robot facing +y is +0.2 in world y.
    assert close(pose.translation, (1.0, 2.2, 0.2))
    assert same_rotation(pose.rotation, yaw(math.pi / 2))


def test_lookup_upwards_is_the_inverse(tree):
    down = tree.lookup('world', 'robot/laser_link')
    up = tree.lookup('robot/laser_link', 'world')
    identity = down.compose(up)
    assert close(identity.translation, (0.0, 0.0, 0.0))
    assert same_rotation(identity.rotation, (0.0, 0.0, 0.0, 1.0))


def test_lookup_across_branches_goes_through_the_common_ancestor(tree):
    pose = tree.lookup('camera', 'robot/base_link')
    # The camera is turned by pi about z at (0, 0, 5): world (1, 2, 0.1) is (-1, -2, -4.9) in it.
    assert close(pose.translation, (-1.0, -2.0, -4.9))
    assert same_rotation(pose.rotation, yaw(-math.pi / 2))
    point = pose.apply((1.0, 0.0, 0.0))  # 1 m ahead of the robot: world (1, 3, 0.1)
    assert close(point, (-1.0, -3.0, -4.9))


def test_a_newer_transform_of_a_child_replaces_the_older(tree):
    tree.add('world', 'robot/base_link', Pose((5.0, 5.0, 0.0)))
    assert close(tree.lookup('world', 'robot/laser_link').translation, (5.2, 5.0, 0.1))


def test_unknown_or_disconnected_frames_are_refused(tree):
    with pytest.raises(TfLookupError, match="'nowhere' is not in the tree"):
        tree.lookup('world', 'nowhere')
    tree.add('map', 'odom', Pose())
    with pytest.raises(TfLookupError, match='not connected'):
        tree.lookup('world', 'odom')


@pytest.mark.parametrize('parent, child, pose, problem', [
    ('world', 'world', Pose(), 'own parent'),
    ('', 'a', Pose(), 'must not be empty'),
    ('robot/laser_link', 'world', Pose(), 'loop'),
])
def test_bad_transforms_are_refused(tree, parent, child, pose, problem):
    with pytest.raises(ValueError, match=problem):
        tree.add(parent, child, pose)


def test_pose_refuses_a_non_unit_or_non_finite_rotation():
    with pytest.raises(ValueError, match='unit quaternion'):
        Pose((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 2.0))
    with pytest.raises(ValueError, match='finite'):
        Pose((math.nan, 0.0, 0.0))
