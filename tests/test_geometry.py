import numpy as np

from mjtrack.geometry import (
    body_to_world_velocity,
    compose,
    euler_step,
    relative_pose,
    rot2,
    se2_step,
    world_to_body_velocity,
    wrap_angle,
)


def test_rot2_is_rotation(rng):
    th = rng.uniform(-10, 10, 100)
    r = rot2(th)
    assert np.allclose(r @ np.swapaxes(r, -1, -2), np.eye(2), atol=1e-14)
    assert np.allclose(np.linalg.det(r), 1.0)


def test_wrap_angle_range_and_equivalence(rng):
    a = rng.uniform(-50, 50, 1000)
    w = wrap_angle(a)
    assert np.all(w >= -np.pi) and np.all(w < np.pi)
    assert np.allclose(np.cos(w), np.cos(a)) and np.allclose(np.sin(w), np.sin(a))


def test_body_world_velocity_round_trip(rng):
    yaw, vx, vy = rng.normal(size=(3, 500))
    xd, yd = body_to_world_velocity(yaw, vx, vy)
    bx, by = world_to_body_velocity(yaw, xd, yd)
    assert np.allclose(bx, vx, atol=1e-14) and np.allclose(by, vy, atol=1e-14)


def test_se2_step_circle():
    # vx = 1 m/s, wz = 1 rad/s for pi s: half circle of radius 1 to the left.
    p = se2_step(np.zeros(3), np.array([1.0, 0.0, 1.0]), np.pi)
    assert np.allclose(p, [0.0, 2.0, np.pi], atol=1e-14)


def test_se2_step_group_property_and_euler_limit():
    for wz in (0.7, 1e-6, 0.0, -3e-5):
        twist = np.array([0.8, -0.1, wz])
        p0 = np.array([0.3, -0.2, 0.5])
        exact = se2_step(p0, twist, 2.0)
        # composing many small exact steps must equal one big step (group property) ...
        q = p0.copy()
        for _ in range(1000):
            q = se2_step(q, twist, 2.0 / 1000)
        assert np.allclose(exact, q, atol=1e-12)
        # ... and many small Euler steps converge to it (first order: error ~ 1/n)
        r = p0.copy()
        for _ in range(20000):
            r = euler_step(r, twist, 2.0 / 20000)
        assert np.allclose(exact, r, atol=1e-4)


def test_se2_step_continuous_across_series_threshold():
    twist = np.array([1.0, 0.2, 0.0])
    dt = 1.0
    below = se2_step(np.zeros(3), twist + [0, 0, 0.99999e-4], dt)
    above = se2_step(np.zeros(3), twist + [0, 0, 1.00001e-4], dt)
    assert np.allclose(below, above, atol=1e-9)


def test_relative_pose_compose_round_trip(rng):
    a = rng.normal(size=(200, 3))
    b = rng.normal(size=(200, 3))
    d = relative_pose(a, b)
    back = compose(a, d)
    assert np.allclose(back[:, :2], b[:, :2], atol=1e-12)
    assert np.allclose(wrap_angle(back[:, 2] - b[:, 2]), 0.0, atol=1e-12)
