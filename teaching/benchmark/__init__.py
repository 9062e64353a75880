"""The teaching benchmark: every registered selector on a table, learnt by every simulated learner, under several
seeds (``python -m teaching benchmark``; docs/benchmark.md).  cells: what one unit of work is and its content
address; run: computing cells into a results folder, resumably; summary: means and 95 % intervals over seeds."""
