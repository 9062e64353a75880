"""What a participant's page shows of a trajectory: the domain's scene draws its path rows, or, for a robot with
the optional :class:`~teaching.core.domain.RecordingsPart` (an imported table with videos), the page plays the
recording the domain names (docs/domains.md, "RecordingsPart")."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .domain import RecordingsPart, has_part


def stimulus_of(domain, env_id: int, theta_index: int, states: np.ndarray):
    """What a page shows of objective `theta_index`'s trajectory `states` in environment `env_id`: the domain's
    recording of it (RecordingsPart), else its path_rows, which the domain's scene draws."""
    if has_part(domain, RecordingsPart):
        return domain.stimulus(int(env_id), int(theta_index), states)
    return domain.path_rows(states)


def recording_file(domain, name: str) -> Path | None:
    """The file of `domain`'s recording `name`; None for a name that is not one, or a domain with none."""
    return domain.media_file(name) if has_part(domain, RecordingsPart) else None
