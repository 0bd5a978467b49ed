"""The test suite's own machinery (not part of the installed package).

* :mod:`support.repo`: where the repository's tests, benchmark scripts, result files and
  documentation are, and loading a benchmark script as a module.
* :mod:`support.cli`: run ``mjtrack ARGS`` in-process or in a subprocess and check its exit
  status and error line; :class:`support.cli.Forker` runs command lines as real processes forked
  from a warm one (``cli_zygote.py``), under a memory cap, a time limit and signals.
* :mod:`support.builder_fingerprints`: hashes of the compiled MuJoCo models, a detector of
  unintended model changes.

The tests import it as ``support`` (pytest puts the ``tests`` folder on the import path, as it
has no ``__init__.py``). The oracles users may want as well (independent physics generators)
are in :mod:`mjtrack.testing`.
"""
