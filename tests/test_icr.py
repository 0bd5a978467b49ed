import numpy as np
import pytest

from mjtrack.errors import SingularMotionError
from mjtrack.icr import (
    centre_from_sphere,
    course_angle,
    icr_from_twist,
    slip_ratio,
    sphere_from_centre,
    twist_from_icr,
    virtual_robot_from_icr,
    virtual_robot_from_twist,
)
from mjtrack.models import MVIR


def _random_motion(rng, n=5000):
    vx = rng.uniform(-2, 2, n)
    vy = rng.uniform(-0.5, 0.5, n)
    wz = rng.uniform(0.05, 3.0, n) * rng.choice([-1.0, 1.0], n)  # bounded away from 0
    vl = rng.uniform(-2, 2, n)
    # choose V_R so that the motion is consistent with some finite y_l != y_r
    vr = vl + wz * rng.uniform(0.1, 2.0, n)
    return vx, vy, wz, vl, vr


def test_icr_round_trip_returns_twist(rng):
    vx, vy, wz, vl, vr = _random_motion(rng)
    icr = icr_from_twist(vx, vy, wz, vl, vr)
    assert icr.valid.all()
    back = twist_from_icr(icr.y_l, icr.y_r, icr.x_c, vl, vr)
    assert np.max(np.abs(back - np.stack([vx, vy, wz], -1))) < 1e-12


def test_icr_of_nominal_motion_is_half_gauge(rng):
    t = 0.4
    vl, vr = rng.uniform(-1, 1, (2, 100))
    vr = np.where(np.abs(vr - vl) < 1e-3, vr + 0.1, vr)
    vx, wz = (vl + vr) / 2, (vr - vl) / t
    icr = icr_from_twist(vx, 0.0, wz, vl, vr)
    assert np.allclose(icr.y_l, t / 2) and np.allclose(icr.y_r, -t / 2) and np.allclose(icr.x_c, 0)


def test_icr_body_point_is_at_rest():
    twist = np.array([0.3, -0.05, 0.7])
    icr = icr_from_twist(*twist, 0.1, 0.6)
    # body velocity at the body ICR vanishes
    assert abs(twist[0] - twist[2] * icr.y_c) < 1e-15 and abs(twist[1] + twist[2] * icr.x_c) < 1e-15
    # the left track surface at (x_c, y_l) is at rest on the ground
    assert abs(twist[0] - twist[2] * icr.y_l - 0.1) < 1e-15


def test_straight_motion_raises_or_masks():
    with pytest.raises(SingularMotionError, match="straight motion"):
        icr_from_twist(1.0, 0.0, 0.0, 1.0, 1.0)
    icr = icr_from_twist([1.0, 1.0], [0.0, 0.0], [0.0, 0.5], [1.0, 0.9], [1.0, 1.1], on_singular="mask")
    assert icr.valid.tolist() == [False, True]
    assert np.isnan(icr.y_l[0]) and np.isfinite(icr.y_l[1])
    with pytest.raises(ValueError, match="on_singular"):
        icr_from_twist(1.0, 0.0, 0.5, 1.0, 1.0, on_singular="ignore")


def test_twist_from_coincident_icrs_raises():
    with pytest.raises(SingularMotionError, match="coincide"):
        twist_from_icr(0.2, 0.2, 0.0, 1.0, 1.0)


def test_virtual_robot_reproduces_twist_exactly(rng):
    vx, vy, wz, vl, vr = _random_motion(rng)
    vir = virtual_robot_from_twist(vx, vy, wz, vl, vr)
    twist = MVIR(vir.x_o, vir.y_o, vir.track).twist(vl, vr)
    assert np.max(np.abs(twist - np.stack([vx, vy, wz], -1))) < 1e-12


def test_printed_sign_of_2_17_does_not_reproduce_twist():
    # The thesis prints y_o = (V_R + V_L - 2 vx)/(2 w); under the thesis's own conventions the
    # virtual robot built with it predicts a different vx (this is why we use the opposite sign).
    vx, wz, vl, vr = 0.5, 0.4, 0.2, 0.5  # vy = 0
    printed_y_o = (vr + vl - 2 * vx) / (2 * wz)
    tv = (vr - vl) / wz
    assert abs(MVIR(0.0, printed_y_o, tv).twist(vl, vr)[0] - vx) > 0.1


def test_virtual_wheels_sit_on_track_icrs(rng):
    vx, vy, wz, vl, vr = _random_motion(rng, 200)
    icr = icr_from_twist(vx, vy, wz, vl, vr)
    vir = virtual_robot_from_twist(vx, vy, wz, vl, vr)
    x_o, y_o, tv = virtual_robot_from_icr(icr.y_l, icr.y_r, icr.x_c)
    assert np.allclose(x_o, vir.x_o) and np.allclose(y_o, vir.y_o) and np.allclose(tv, vir.track)


def test_course_angle_matches_thesis_correction_up_to_sign():
    # centre of a virtual robot ahead of the geometric centre by x_o, turning left:
    x_o, wz, vx = 0.05, 0.5, 0.4
    vy = -wz * x_o
    speed = np.hypot(vx, vy)
    assert np.isclose(np.sin(course_angle(vx, vy)), -x_o * wz / speed)


def test_slip_ratio_sign_safe():
    assert np.isclose(slip_ratio(1.0, 0.8), 0.2)  # traction slip, forward
    assert np.isclose(slip_ratio(-1.0, -0.8), 0.2)  # traction slip, reversing: same sign
    assert np.isclose(slip_ratio(1.0, 1.25), -0.2)  # skid
    assert np.isclose(slip_ratio(-1.0, -1.25), -0.2)
    assert slip_ratio(0.0, 0.0) == 0.0
    s = slip_ratio(np.linspace(-2, 2, 41), np.linspace(-1.5, 1.9, 41))
    assert np.all(np.isfinite(s))
    # the MPP parameter convention V_r = V (1 - s) agrees whenever |V_r| <= |V|
    v, s0 = -0.7, 0.15
    assert np.isclose(slip_ratio(v, v * (1 - s0)), s0)


def test_unit_sphere_round_trip(rng):
    x_o, y_o = rng.normal(scale=3.0, size=(2, 1000))
    s = sphere_from_centre(x_o, y_o)
    assert np.allclose(np.linalg.norm(s, axis=-1), 1.0)
    assert np.all(s[..., 2] > 0)
    xb, yb = centre_from_sphere(s)
    assert np.allclose(xb, x_o, atol=1e-12) and np.allclose(yb, y_o, atol=1e-12)
    xs, ys = centre_from_sphere(3.7 * s)  # scale-free
    assert np.allclose(xs, x_o) and np.allclose(ys, y_o)
    with pytest.raises(SingularMotionError):
        centre_from_sphere(np.array([1.0, 0.0, 0.0]))
