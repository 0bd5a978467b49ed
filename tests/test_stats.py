"""The cluster-robust sandwich (mjtrack.stats) against examples worked by hand and an explicit
loop over the clusters with a plain matrix inverse."""

from __future__ import annotations

import numpy as np
import pytest

from mjtrack.stats import cluster_sandwich, gram_inverse, t_quantile


def test_one_parameter_worked_by_hand():
    # A = 4; scores 1 - 1 = 0 and 2 + 0 = 2; meat 4, times C/(C-1) = 2: 8; cov = 8 / 4^2
    jac = np.ones((4, 1))
    cov = cluster_sandwich(jac, np.array([1.0, -1.0, 2.0, 0.0]), np.array([0, 0, 1, 1]))
    assert cov == pytest.approx(np.array([[0.5]]), rel=1e-14)


def test_two_parameters_worked_by_hand():
    # A = 3 I; scores (1, 2) and (0, -2); meat [[1, 2], [2, 8]] times 2, over 9
    jac = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, -1.0]])
    cov = cluster_sandwich(jac, np.array([1.0, 2.0, -1.0, 1.0]), np.array(["a", "a", "b", "b"]))
    np.testing.assert_allclose(cov, np.array([[2.0, 4.0], [4.0, 16.0]]) / 9.0, rtol=1e-14)


def test_matches_a_loop_over_the_clusters():
    rng = np.random.default_rng(3)
    jac = rng.normal(size=(60, 3))
    resid = rng.normal(size=60)
    labels = rng.integers(0, 7, size=60) * 10  # interleaved, not consecutive, not 0..C-1
    a_inv = np.linalg.inv(jac.T @ jac)
    ids = np.unique(labels)
    meat = np.zeros((3, 3))
    for c in ids:
        rows = labels == c
        g = jac[rows].T @ resid[rows]
        meat += np.outer(g, g)
    expected = a_inv @ meat @ a_inv * ids.size / (ids.size - 1)
    np.testing.assert_allclose(cluster_sandwich(jac, resid, labels), expected, rtol=1e-10)
    # a floor far below the smallest eigenvalue changes nothing
    np.testing.assert_allclose(cluster_sandwich(jac, resid, labels, eig_floor=1e-12), expected, rtol=1e-10)


def test_a_direction_the_rows_do_not_see():
    # A = diag(2, 0): the pseudo-inverse gives it no variance, a floor a large finite one
    jac = np.array([[1.0, 0.0], [1.0, 0.0]])
    np.testing.assert_allclose(gram_inverse(jac), np.diag([0.5, 0.0]), atol=1e-15)
    np.testing.assert_allclose(gram_inverse(jac, eig_floor=1e-12), np.diag([0.5, 0.5e12]), rtol=1e-12)
    cov = cluster_sandwich(jac, np.array([1.0, 3.0]), np.array([0, 1]))
    # scores (1, 0) and (3, 0): meat 10 times 2, over 2^2
    np.testing.assert_allclose(cov, np.diag([5.0, 0.0]), atol=1e-14)


def test_student_quantile():
    assert t_quantile(2) == pytest.approx(12.7062, abs=1e-4)  # one degree of freedom (tables)
    assert t_quantile(11) == pytest.approx(2.2281, abs=1e-4)  # ten
    assert t_quantile(1) == t_quantile(2)  # never fewer than one
