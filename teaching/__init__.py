"""Algorithmic teaching of a robot's objective (Huang et al.): the numeric core and its domains.

Pure Python + NumPy/SciPy/Numba; never imports Django.  ``teaching.core`` is the algorithm and
knows no robot (learners, selection, evaluation, test set, tables); ``teaching.domains`` holds
the robots, each behind the :class:`~teaching.core.domain.Domain` interface.  Data flows one
way: domain (world -> planner) -> trajectory table -> learners -> selection -> evaluation.
"""
from . import domains  # noqa: F401  (registers the built-in domains)
