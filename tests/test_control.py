"""Controllers of the wheeled-robot thesis (chapter 3) on the wheeled models.

Start poses and goals are the thesis's where legible (figs. 3.5-3.24): static goal (0, 0) from
A..H on a circle of radius 3 m (6 m for the skid steer) with yaw 0; posture goal (0, 0, pi/2)
from (+-3, 0), (0, +-3); moving goal on a circle of radius 1 m from (0, -1), robot from
(-1.5, -1); tracking circle R = 0.5 m at 1 m/s, w = 2 rad/s, robot starting off the circle.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjtrack.control import (
    AckermannAdapter,
    ConstantSpeedProfile,
    FeedForward,
    LineFollower,
    Plant,
    PolarPostureController,
    Polyline,
    ReactiveController,
    Reference,
    TrackedKinematic,
    TrackSpeedAdapter,
    TrajectoryTracker,
    TriangularProfile,
    WheelSpeedAdapter,
    circle_path,
    error_matrix,
    figure_eight_path,
    lane_change_path,
    placement_gains,
    polar_error,
    run_closed_loop,
    tracking_error,
)
from mjtrack.control.tracking import B_MATRIX
from mjtrack.errors import InputError
from mjtrack.models.kinematic import MPP, Nominal
from mjtrack.models.wheeled import Ackermann, DiffDriveDynamic1, DiffDriveKinematic, SkidSteer4

R3 = 3 / math.sqrt(2)
STARTS_3M = [(3, 0), (R3, R3), (0, 3), (-R3, R3), (-3, 0), (-R3, -R3), (0, -3), (R3, -R3)]


# ---------------------------------------------------------------- adapters and paths

def test_adapters_invert_the_models():
    rng = np.random.default_rng(2)
    dd = DiffDriveKinematic()
    car = Ackermann(drive="front")
    for v, w in rng.uniform(-1, 1, size=(5, 2)):
        np.testing.assert_allclose(dd.twist(None, WheelSpeedAdapter(dd.track, dd.wheel_radius)(v, w)), [v, 0, w])
        vl, vr = TrackSpeedAdapter(0.4)(v, w)
        np.testing.assert_allclose(Nominal(0.4).twist(vl, vr), [v, 0, w])
        v = abs(v) + 0.1  # the car's feasible set: |w| <= |v| tan(max_steer)/l
        w = 0.5 * w * v * math.tan(car.max_steer) / car.wheelbase
        np.testing.assert_allclose(car.body_rates(Plant.of(car).adapter(v, w)), [v, w])
    assert AckermannAdapter(0.3, 0.5)(0.0, 1.0)[1] == 0.5


def test_circle_path_radius_and_length():
    path = circle_path(centre=(1.0, 2.0), radius=0.7)
    u = np.linspace(0, 2 * math.pi, 7)
    np.testing.assert_allclose(path.radius(u), 0.7)
    assert path.length == pytest.approx(2 * math.pi * 0.7, rel=1e-12)
    np.testing.assert_allclose(path.arc_length(u), 0.7 * u, atol=1e-9)
    np.testing.assert_allclose(path.u_at(0.7 * u), u, atol=1e-9)


def test_figure_eight_curvature_matches_finite_differences():
    path = figure_eight_path(size=2.0)
    u = np.linspace(0.1, 6.0, 13)
    h = 1e-5
    heading = np.unwrap(path.heading(np.stack([u - h, u + h])), axis=0)
    ds = np.hypot(*(path.point(u + h) - path.point(u - h)).T)  # chord = arc to O(h^3)
    np.testing.assert_allclose((heading[1] - heading[0]) / ds, path.curvature(u), rtol=1e-4, atol=1e-6)
    assert path.curvature(math.pi / 2) == pytest.approx(-0.5)


def test_figure_eight_arc_length_matches_quadrature():
    from scipy.integrate import quad

    path = figure_eight_path(size=2.0)
    for u in (0.7, 2.0, 5.5, 2 * math.pi):
        exact = quad(lambda x: 2.0 * math.hypot(math.cos(x), math.cos(2 * x)), 0.0, u, limit=200)[0]
        assert path.arc_length(u) == pytest.approx(exact, abs=1e-5)


def test_lane_change_path_shifts_with_continuous_curvature():
    path = lane_change_path(shift=1.0, length=3.0, lead_in=1.5, lead_out=1.5)
    np.testing.assert_allclose(path.point(np.array([0.0, 1.5, 4.5, 6.0])), [[0, 0], [1.5, 0], [4.5, 1.0], [6.0, 1.0]], atol=1e-12)
    u = np.linspace(0.2, 5.8, 29)
    h = 1e-5
    heading = path.heading(np.stack([u - h, u + h]))
    ds = np.hypot(*(path.point(u + h) - path.point(u - h)).T)
    np.testing.assert_allclose((heading[1] - heading[0]) / ds, path.curvature(u), rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(path.curvature(np.array([1.5, 3.0, 4.5])), 0.0, atol=1e-12)  # no step at the ends
    k_max = np.max(np.abs(path.curvature(np.linspace(1.5, 4.5, 3001))))
    assert k_max == pytest.approx(0.617, abs=0.002)  # y'' peaks at 2 pi h / l^2 = 0.70, reduced by the slope
    assert path.curvature(2.25) > 0 > path.curvature(3.75)
    from scipy.integrate import quad

    exact = 3.0 + quad(lambda x: math.hypot(1.0, (1 - math.cos(2 * math.pi * x / 3)) / 3), 0, 3)[0]
    assert path.length == pytest.approx(exact, rel=1e-6)


def test_polyline_signed_distance():
    line = Polyline(np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]))
    assert line.closest((0.5, 0.2))[:2] == (pytest.approx(0.2), pytest.approx(0.5))
    assert line.closest((0.5, -0.2))[0] == pytest.approx(-0.2)
    assert line.closest((1.3, 0.5))[:2] == (pytest.approx(-0.3), pytest.approx(1.5))
    with pytest.raises(InputError, match="coincide"):
        Polyline(np.array([[0.0, 0.0], [0.0, 0.0]]))


# ---------------------------------------------------------------- feed-forward (3.1)-(3.4)

def test_triangular_profile_stops_at_the_end():
    prof = TriangularProfile(length=10.0, accel=0.2)
    assert prof.duration == pytest.approx(2 * math.sqrt(50.0))
    assert prof.distance(prof.duration / 2) == pytest.approx(5.0)
    assert prof.speed(prof.duration / 2) == pytest.approx(math.sqrt(0.2 * 10.0))
    assert prof.distance(prof.duration) == 10.0 and prof.speed(prof.duration) == 0.0
    t = np.linspace(0, prof.duration, 2001)
    s = np.array([prof.distance(x) for x in t])
    v = np.array([prof.speed(x) for x in t])
    np.testing.assert_allclose(np.gradient(s, t)[1:-1], v[1:-1], atol=2e-3)


@pytest.mark.parametrize("profile", ["constant", "triangular"])
def test_feedforward_drives_the_figure_eight(profile):
    """Open loop from the reference start pose the kinematic robot stays on the path; the
    residual comes from holding each sampled command for the 10 ms period (zero-order hold)."""
    path = figure_eight_path(size=2.0)
    prof = ConstantSpeedProfile(path.length, 0.5) if profile == "constant" else TriangularProfile(path.length, 0.2)
    ref = Reference(path, prof)
    res = run_closed_loop(Plant.of(DiffDriveKinematic()), FeedForward(ref), ref.duration, 0.01, pose0=ref.start_pose())
    err = np.hypot(*(res.poses[:, :2] - np.array([ref.at(t).pose[:2] for t in res.t])).T)
    # ZOH: each held command lags the reference by dt/2 in heading; the position error stays
    # below 1 cm over the 12 m lap (measured 5.0 mm constant, 7.8 mm triangular)
    assert err.max() < 0.01
    np.testing.assert_allclose(res.poses[-1, :2], path.point(path.u_end), atol=0.01)
    if profile == "triangular":
        assert res.commands[-1].tolist() == [0.0, 0.0]


def test_feedforward_from_a_wrong_start_misses_the_path():
    """Thesis fig. 3.1: identical commands from another start pose give a displaced path."""
    path = circle_path(radius=1.0)
    ref = Reference(path, ConstantSpeedProfile(path.length, 1.0))
    res = run_closed_loop(Plant.of(DiffDriveKinematic()), FeedForward(ref), ref.duration, 0.01, pose0=(0.3, -1.0, 0.2))
    assert np.hypot(*(res.poses[-1, :2] - path.point(path.u_end))) > 0.25


# ---------------------------------------------------------------- reactive (3.5)-(3.6)

@pytest.mark.parametrize("start", STARTS_3M)
def test_reactive_static_goal_dynamic1(start):
    """Fig. 3.7: dynamic model 1, goal (0, 0), b = 5 rad/s, c = 0, d = 0.8 rad/s, K_R = 1, v_max = 1 m/s."""
    ctrl = ReactiveController((0.0, 0.0), fov=math.pi / 4, b=5.0, c=0.0, d=0.8, distance_gain=1.0, v_max=1.0)
    res = run_closed_loop(Plant.of(DiffDriveDynamic1()), ctrl, 10.0, 0.01, pose0=(*start, 0.0), substeps=4)
    dist = np.hypot(res.poses[:, 0], res.poses[:, 1])
    assert dist[-1] < ctrl.stop_radius
    assert np.all(np.abs(res.commands[:, 0]) <= 1.0 + 1e-12)


def test_reactive_without_distance_regulator_overshoots():
    """Fig. 3.5-3.6: with constant a the robot passes the goal and turns back."""
    ctrl = ReactiveController((0.0, 0.0), a=1.0, b=5.0, c=0.0, d=0.8, stop_radius=1e-6)
    res = run_closed_loop(Plant.of(DiffDriveDynamic1()), ctrl, 12.0, 0.01, pose0=(3.0, 0.0, 0.0), substeps=4)
    dist = np.hypot(res.poses[:, 0], res.poses[:, 1])
    k_pass = int(np.argmin(dist[res.t < 7.0]))
    k_far = k_pass + int(np.argmax(dist[k_pass:]))
    assert dist[k_pass] < 0.01  # drives through the goal at full speed a = 1 m/s ...
    assert dist[k_far] > 0.08  # ... carries on past it (turn-on-the-spot only once out of view) ...
    assert dist[-1] < 0.5 * dist[k_far]  # ... and comes back


def _goal_on_circle(speed, radius=1.0):
    return lambda t: (radius * math.sin(speed * t / radius), -radius * math.cos(speed * t / radius))


def test_reactive_keeps_distance_to_a_moving_goal_dynamic1():
    """Fig. 3.9-3.12: goal at 0.5 m/s on a 1 m circle from (0, -1), robot from (-1.5, -1), PI on the distance."""
    ctrl = ReactiveController(_goal_on_circle(0.5), b=5.0, c=0.0, d=0.8, distance_gain=1.0, integral_gain=0.5,
                              set_distance=0.2, v_max=1.0)
    res = run_closed_loop(Plant.of(DiffDriveDynamic1()), ctrl, 20.0, 0.01, pose0=(-1.5, -1.0, 0.0), substeps=4)
    goal = np.array([ctrl.goal_at(t) for t in res.t])
    dist = np.hypot(*(res.poses[:, :2] - goal).T)
    assert np.all(np.abs(dist[res.t >= 15.0] - 0.2) < 0.005)  # measured: within 1 mm from 15 s


@pytest.mark.parametrize("start", STARTS_3M[::2])
def test_reactive_static_goal_ackermann(start):
    """Fig. 3.13: rear-drive car, the law steers theta = b sin(psi) / d sign(psi); c = 0.5 m/s, d = pi/4,
    K_R = 1, v_max = 0.5 m/s.  A car cannot turn on the spot: it stops within 5 cm."""
    car = Ackermann()
    ctrl = ReactiveController((0.0, 0.0), b=1.0, c=0.5, d=math.pi / 4, distance_gain=1.0, v_max=0.5,
                              steering_wheelbase=car.wheelbase, stop_radius=0.05)
    res = run_closed_loop(Plant.of(car), ctrl, 15.0, 0.02, pose0=(*start, 0.0))
    assert np.hypot(*res.poses[-1, :2]) < 0.05


def test_reactive_moving_goal_ackermann():
    """Fig. 3.14-3.15: car chases a goal at 0.2 m/s on the 1 m circle, PI K_P = 1, K_I = 0.35."""
    car = Ackermann()
    ctrl = ReactiveController(_goal_on_circle(0.2), b=1.0, c=0.5, d=math.pi / 4, distance_gain=1.0,
                              integral_gain=0.35, set_distance=0.2, v_max=0.5, steering_wheelbase=car.wheelbase)
    res = run_closed_loop(Plant.of(car), ctrl, 30.0, 0.02, pose0=(-1.5, -1.0, 0.0))
    goal = np.array([ctrl.goal_at(t) for t in res.t])
    dist = np.hypot(*(res.poses[:, :2] - goal).T)
    assert np.all(np.abs(dist[res.t >= 20.0] - 0.2) < 0.005)


@pytest.mark.parametrize("start", [(6.0, 0.0), (-6.0, 0.0)])
def test_reactive_static_goal_skid_steer(start):
    """Fig. 3.16: skid steer from 6 m, wheel speeds by (1.3), K_R = 0.5, v_max = 0.5 m/s."""
    ctrl = ReactiveController((0.0, 0.0), b=5.0, c=0.0, d=0.8, distance_gain=0.5, v_max=0.5, stop_radius=0.05)
    model = SkidSteer4()
    res = run_closed_loop(Plant.of(model), ctrl, 25.0, 0.01, pose0=(*start, 0.0), substeps=6)
    assert np.hypot(*res.poses[-1, :2]) < 0.05


# ---------------------------------------------------------------- posture (3.7)-(3.10)

def test_polar_error_definition():
    rho, alpha, beta = polar_error((1.0, 0.0, math.pi / 2), (0.0, 0.0, 0.0))
    assert (rho, alpha, beta) == (pytest.approx(1.0), pytest.approx(math.pi / 2), pytest.approx(-math.pi))


@pytest.mark.parametrize("start", [(3.0, 0.0), (0.0, 3.0), (-3.0, 0.0), (0.0, -3.0)])
def test_posture_reaches_goal_pose(start):
    """Fig. 3.18: goal (0, 0, pi/2), starts A-D with yaw 0 (A and B lie behind: the robot reverses)."""
    ctrl = PolarPostureController((0.0, 0.0, math.pi / 2), v_max=1.0)
    res = run_closed_loop(Plant.of(DiffDriveKinematic()), ctrl, 12.0, 0.01, pose0=(*start, 0.0))
    x, y, yaw = res.poses[-1]
    assert math.hypot(x, y) < 2e-3
    assert abs(yaw - math.pi / 2) < 2e-3
    reversing = start[0] > 0 or start[1] > 0
    assert (res.commands[1, 0] < 0) == reversing


def test_posture_on_dynamic_model():
    ctrl = PolarPostureController((1.0, 1.0, -math.pi / 2), v_max=0.5, position_tol=5e-3, heading_tol=5e-3)
    res = run_closed_loop(Plant.of(DiffDriveDynamic1()), ctrl, 15.0, 0.01, pose0=(-1.0, 0.0, 0.0), substeps=4)
    x, y, yaw = res.poses[-1]
    assert math.hypot(x - 1.0, y - 1.0) < 1e-2 and abs(yaw + math.pi / 2) < 1e-2


def test_posture_rejects_unstable_gains():
    with pytest.raises(InputError, match="k_beta < 0"):
        PolarPostureController((0, 0, 0), k_beta=0.5)


# ---------------------------------------------------------------- line following (3.2.2)

def _wave(length, amplitude, wavelength):
    x = np.linspace(0.0, length, 201)
    return Polyline(np.stack([x, amplitude * np.sin(2 * math.pi * x / wavelength)], 1))


@pytest.mark.parametrize("spacing", [0.02, 0.04])
def test_line_following_differential_drive(spacing):
    """Fig. 3.20: 0.3 m/s, sensors 0.04 m ahead; the sensors' midpoint stays within the spacing/2
    of the line (plus one sample of travel) and the robot stops at the line's end."""
    line = _wave(1.8, 0.2, 1.2)
    ctrl = LineFollower(line, speed=0.3, turn_rate=3.0, sensor_ahead=0.04, sensor_spacing=spacing)
    res = run_closed_loop(Plant.of(DiffDriveKinematic()), ctrl, 10.0, 0.01, pose0=(0.0, 0.0, math.atan(0.2 * 2 * math.pi / 1.2)))
    mid = np.array([ctrl.sensor_points(p).mean(axis=0) for p in res.poses])
    err = np.abs([line.closest(m)[0] for m in mid])
    assert err.max() < spacing / 2 + 0.3 * 0.01
    assert np.all(res.commands[-1] == 0.0)
    assert np.hypot(*(mid[-1] - line.points[-1])) < 0.02


@pytest.mark.parametrize("spacing", [0.06, 0.08])
def test_line_following_ackermann(spacing):
    """Fig. 3.22: car at 0.3 m/s, sensors 0.35 m ahead of B, bang-bang steering +-30 deg; start
    with the sensors on the line's start."""
    car = Ackermann(max_steer=math.radians(30))
    line = _wave(3.0, 0.3, 3.0)
    ctrl = LineFollower(line, speed=0.3, turn_rate=0.3 * math.tan(car.max_steer) / car.wheelbase, sensor_ahead=0.35,
                        sensor_spacing=spacing)
    res = run_closed_loop(Plant.of(car), ctrl, 12.0, 0.01, pose0=(-0.35, 0.0, 0.0))
    mid = np.array([ctrl.sensor_points(p).mean(axis=0) for p in res.poses])
    err = np.abs([line.closest(m)[0] for m in mid])
    assert err.max() < spacing / 2 + 0.3 * 0.01
    assert np.all(res.commands[-1] == 0.0)


# ---------------------------------------------------------------- trajectory tracking (3.11)-(3.21)

@pytest.mark.parametrize("v_d, w_d", [(1.0, 2.0), (0.5, 0.0), (0.0, 1.0), (-0.3, 0.7)])
def test_pole_placement_gives_the_chosen_eigenvalues(v_d, w_d):
    poles = np.array([-1.0, -2.0, -4.0])
    k = placement_gains(v_d, w_d, poles)
    eig = np.sort(np.linalg.eigvals(error_matrix(v_d, w_d) - B_MATRIX @ k).real)
    np.testing.assert_allclose(eig, np.sort(poles), atol=1e-9)


def test_error_dynamics_linearisation_matches_finite_differences():
    """A of (3.19) is the Jacobian of the exact error dynamics (3.15) at e = 0, u = 0."""
    v_d, w_d = 0.8, -1.3

    def edot(e, u):
        v, w = v_d * math.cos(e[2]) - u[0], w_d - u[1]
        return np.array([w * e[1] - v + v_d * math.cos(e[2]), -w * e[0] + v_d * math.sin(e[2]), w_d - w])

    h = 1e-6
    jac_e = np.column_stack([(edot(h * ei, np.zeros(2)) - edot(-h * ei, np.zeros(2))) / (2 * h) for ei in np.eye(3)])
    jac_u = np.column_stack([(edot(np.zeros(3), h * ui) - edot(np.zeros(3), -h * ui)) / (2 * h) for ui in np.eye(2)])
    np.testing.assert_allclose(jac_e, error_matrix(v_d, w_d), atol=1e-8)
    np.testing.assert_allclose(jac_u, B_MATRIX, atol=1e-8)


def test_tracking_error_is_in_the_robot_frame():
    e = tracking_error((1.0, 1.0, math.pi / 2), (1.0, 2.0, math.pi / 2 + 0.1))
    np.testing.assert_allclose(e, [1.0, 0.0, 0.1], atol=1e-12)


@pytest.mark.parametrize("start", [(0.0, 0.0, 0.0), (-0.2, -0.1, 0.3), (0.0, 0.0, math.pi / 2)])
def test_tracking_circle_from_a_wrong_start_dynamic1(start):
    """Fig. 3.24-3.25: circle R = 0.5 m at v_d = 1 m/s (w_d = 2 rad/s), poles (-1, -2, -4), dynamic
    model 1 starting from rest (so even the on-circle start lags first)."""
    path = circle_path(centre=(0.0, 0.5), radius=0.5, turns=2)
    ref = Reference(path, ConstantSpeedProfile(path.length, 1.0))
    assert (ref.at(0.0).v, ref.at(0.0).w) == (pytest.approx(1.0), pytest.approx(2.0))
    ctrl = TrajectoryTracker(ref, poles=(-1.0, -2.0, -4.0))
    res = run_closed_loop(Plant.of(DiffDriveDynamic1()), ctrl, 6.0, 0.01, pose0=start, substeps=5)
    err = np.array([tracking_error(p, ref.at(t).pose) for t, p in zip(res.t, res.poses)])
    final = np.abs(err[res.t >= 5.0]).max(axis=0)
    assert np.all(final < [5e-3, 1.5e-2, 5e-3])  # slowest pole -1/s: the worst start decays to ~4 mm by 5 s


def test_tracking_triangular_figure_eight_from_standstill_dynamic1():
    """Reference starting and ending at rest (gains of v_floor while v_d = w_d = 0), wrong start."""
    path = figure_eight_path(size=2.0)
    ref = Reference(path, TriangularProfile(path.length, 0.2))
    ctrl = TrajectoryTracker(ref, poles=(-1.0, -2.0, -4.0))
    res = run_closed_loop(Plant.of(DiffDriveDynamic1()), ctrl, ref.duration + 3.0, 0.02, pose0=(0.1, -0.1, 0.3),
                          substeps=10)
    err = np.array([tracking_error(p, ref.at(t).pose) for t, p in zip(res.t, res.poses)])
    assert np.all(np.abs(err[res.t > 5.0]).max(axis=0) < [0.01, 0.02, 0.05])  # measured 6 mm, 10 mm, 0.024 rad
    np.testing.assert_allclose(res.poses[-1, :2], path.point(path.u_end), atol=1e-3)


def test_tracking_with_seeded_measurement_noise():
    """Pose noise (2 mm, 0.01 rad std, seeded) on the circle task: the error stays at the noise level."""
    rng = np.random.default_rng(4)
    path = circle_path(centre=(0.0, 0.5), radius=0.5, turns=2)
    ref = Reference(path, ConstantSpeedProfile(path.length, 1.0))
    res = run_closed_loop(Plant.of(DiffDriveDynamic1()), TrajectoryTracker(ref), 6.0, 0.01, pose0=(-0.2, -0.1, 0.3),
                          substeps=5, measure=lambda t, p: p + rng.normal(scale=[0.002, 0.002, 0.01]))
    err = np.array([tracking_error(p, ref.at(t).pose) for t, p in zip(res.t, res.poses)])
    rms = np.sqrt(np.mean(err[res.t > 4.0] ** 2, axis=0))
    assert np.all(rms < [0.002, 0.004, 0.004])  # measured 0.7 mm, 1.7 mm, 1.6 mrad


def test_tracking_figure_eight_on_a_slipping_tracked_robot():
    """The tracked robot's task: a figure-eight at 0.5 m/s.  With MPP slip the open loop drifts
    away; the tracker, through the track-speed adapter, holds the path."""
    path = figure_eight_path(size=2.0)
    ref = Reference(path, ConstantSpeedProfile(path.length, 0.5))
    plant = Plant.of(TrackedKinematic(MPP(0.4, s_left=0.1, s_right=0.05, alpha=0.05), 0.4))
    assert isinstance(plant.adapter, TrackSpeedAdapter)
    ff = run_closed_loop(plant, FeedForward(ref), ref.duration, 0.02, pose0=ref.start_pose())
    fb = run_closed_loop(plant, TrajectoryTracker(ref, poles=(-2.0, -3.0, -4.0)), ref.duration, 0.02,
                         pose0=ref.start_pose())
    target = np.array([ref.at(t).pose[:2] for t in ff.t])
    err_ff = np.hypot(*(ff.poses[:, :2] - target).T)
    err_fb = np.hypot(*(fb.poses[:, :2] - target).T)
    assert err_ff.max() > 0.5
    assert err_fb.max() < 0.1


def test_run_closed_loop_validates_arguments():
    with pytest.raises(InputError, match="exactly one"):
        run_closed_loop(Plant.of(DiffDriveKinematic()), FeedForward(Reference(circle_path(), ConstantSpeedProfile(2 * math.pi, 1.0))), 1.0, 0.1)
    with pytest.raises(InputError, match="profile covers"):
        Reference(circle_path(), ConstantSpeedProfile(1.0, 1.0))
