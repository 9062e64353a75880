"""The teaching algorithm, for any robot: it sees a domain only through
:class:`teaching.core.domain.Domain` and never imports from ``teaching.domains``
(tests/teaching/test_domains.py checks both)."""
