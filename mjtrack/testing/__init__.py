"""Generators and oracles for mjtrack's tests and benchmarks.

These modules write the truth the tests compare against, so each is kept apart from the code it
is used to check (each module's docstring says what it shares with mjtrack and what it does not):

* :mod:`mjtrack.testing.diagnose_physics`: an independent rigid-body simulation of a skid-steer
  robot with hidden effects (its own contact model and integrator), the truth of the diagnosis
  tests; :mod:`mjtrack.testing.diagnose_logs` names its effects as the diagnosis tests use them.
* :mod:`mjtrack.testing.mujoco_effects`: MuJoCo drive logs with one hidden effect, injected
  without ``mjtrack.diagnose``.
* :mod:`mjtrack.testing.ground_balance`: the steady-state force and moment balance of a rigid
  two-track vehicle on a given ground, by quadrature (oracle of the ground models).
* :mod:`mjtrack.testing.bristle_physics`: a second independent generator of drive logs (bristle
  friction, driven belts with inertia), sharing no code with the first.
* :mod:`mjtrack.testing.implementations` and :mod:`mjtrack.testing.battery`: the cases of the
  diagnosis across implementations and of the calibration battery, with their truth.

The tests' own machinery (running the command line, repository paths, model fingerprints) is
in the repository's ``tests/support``, not in the package.

Nothing in the library imports this package; importing it does not load MuJoCo.
"""
