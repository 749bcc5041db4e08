"""Finite-strain dynamics of hard-magnetic membranes, built from parts.

A :class:`~magfem.mechanics.problem.Problem` is a model
(:mod:`~magfem.mechanics.models`: solid, strip, shell) with a list of loads
(:mod:`~magfem.mechanics.loads`) and a list of contacts
(:mod:`~magfem.mechanics.contacts`); :mod:`~magfem.mechanics.integrator`
discretises it in time, :mod:`~magfem.mechanics.solver` builds the PETSc
solvers, :mod:`~magfem.mechanics.simulation` steps it
(:mod:`~magfem.mechanics.stepping`) while the observers
(:mod:`~magfem.mechanics.observers`) fill the history and the writers
(:mod:`~magfem.mechanics.output`, :mod:`~magfem.mechanics.animation`) save it.
:mod:`magfem.pipeline` composes all of it from a case file.
"""
