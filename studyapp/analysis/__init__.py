"""Analysis of the user study (DESIGN §8): statistics (stats), figures, HTML report, data loading.

``stats``, ``figures`` and ``report`` do not import Django; ``data`` and ``views`` do.
"""
