"""Verification support for magfem's tests and benchmarks (not installed with magfem).

* :mod:`verification.references`: the closed-form and scipy reference
  solutions (hard-magnetic elastica, cantilever frequencies, contact and
  friction laws), with their derivations; no finite elements.
* :mod:`verification.setups`: the cases and runs the mechanics is verified
  with (the cantilever, the membrane on the ground) and the observables
  compared with the references.

Importable from the repository root: pytest adds it to ``sys.path``
(``pythonpath`` in pyproject.toml) and the benchmarks run as
``python -m benchmarks.<name>`` from the root (docs/running.md).
"""
