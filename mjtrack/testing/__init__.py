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
* :mod:`mjtrack.testing.builder_fingerprints`: hashes of the compiled MuJoCo models, a detector
  of unintended model changes.
* :mod:`mjtrack.testing.cli`: run ``mjtrack ARGS`` in-process or in a subprocess and check its
  exit status and error line; :class:`~mjtrack.testing.cli.Forker` runs command lines as real
  processes forked from a warm one (:mod:`mjtrack.testing.cli_zygote`), under a memory cap, a time
  limit and signals.
* :mod:`mjtrack.testing.repo`: where the repository's tests, benchmark scripts and result files
  are (meaningful in a source checkout only).

Nothing in the library imports this package; importing it does not load MuJoCo.
"""
