"""Algorithmic teaching of a car's objective (Huang et al.): the numeric core.

Pure Python + NumPy/SciPy/Numba; never imports Django.  Data flows one way:
world -> environments -> dynamics/features -> planner -> trajectory table ->
learners -> selection -> evaluation.
"""
