"""The fit's secant Jacobian, checked on residuals with a Jacobian written out by hand."""

from __future__ import annotations

import numpy as np

from mjtrack.calibrate.fit import SecantJacobian


def residuals(Z):
    """r(z) = (z0^2 - 1, z0 z1 - 2, sin z1) for points Z (2, k); truth of the slope: jac_true."""
    Z = np.atleast_2d(np.asarray(Z, float).reshape(2, -1))
    return np.stack([Z[0] ** 2 - 1, Z[0] * Z[1] - 2, np.sin(Z[1])])


def jac_true(z):
    return np.array([[2 * z[0], 0.0], [z[1], z[0]], [0.0, np.cos(z[1])]])


BOUNDS = [np.full((2, 1), -10.0), np.full((2, 1), 10.0)]


def test_first_call_is_a_forward_difference_then_the_update_is_exact_along_the_step():
    calls = []

    def counted(Z):
        calls.append(np.asarray(Z).shape[-1])
        return residuals(Z)

    sj = SecantJacobian(counted, 1e-6, BOUNDS)
    x0 = np.array([[1.5], [0.7]])
    J0 = sj(x0, residuals(x0)[:, 0])
    assert np.allclose(J0, jac_true(x0[:, 0]), atol=1e-4) and calls == [2]
    x1 = x0 + np.array([[-0.05], [0.02]])  # a small step that lowers the cost as the slope predicts
    r1 = residuals(x1)[:, 0]
    J1 = sj(x1, r1)
    assert calls == [2] and sj.updates == 1  # no rollout for the update
    # the secant condition: the updated Jacobian maps the step onto the change of the residuals
    assert np.allclose(J1 @ (x1 - x0)[:, 0], r1 - residuals(x0)[:, 0], atol=1e-12)
    # elsewhere it is off by no more than the slope changed over the step (a secant, not a tangent)
    change = np.abs(jac_true(x1[:, 0]) - jac_true(x0[:, 0])).max()
    assert np.abs(J1 - jac_true(x1[:, 0])).max() <= change


def test_a_step_that_falls_short_of_its_prediction_takes_a_fresh_difference():
    sj = SecantJacobian(residuals, 1e-6, BOUNDS)
    x0 = np.array([[1.5], [0.7]])
    sj(x0, residuals(x0)[:, 0])
    x1 = np.array([[-1.2], [3.0]])  # far: the linear model's predicted reduction is not met
    J1 = sj(x1, residuals(x1)[:, 0])
    assert sj.differences == 2 and sj.updates == 0
    assert np.allclose(J1, jac_true(x1[:, 0]), atol=1e-4)
