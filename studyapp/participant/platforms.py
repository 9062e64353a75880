"""Where a participant's recruiting platform takes them back to when they are done: Prolific's completion
address with their code, or Mechanical Turk's submit form (its address checked against an allowlist)."""
from __future__ import annotations

from urllib.parse import urlsplit

from django.utils.translation import gettext

from ..models import Participant

MTURK_HOSTS = {"www.mturk.com", "workersandbox.mturk.com"}


def mturk_submit_base(raw: str) -> str:
    """The MTurk site a worker's answers go back to, from the link's `turkSubmitTo`: exactly
    "https://www.mturk.com" or "https://workersandbox.mturk.com", rebuilt from the allowlist (the
    page's form posts there), or "" when absent; anything else raises ValueError.

    Checking only `urlparse(x).hostname` let `javascript://www.mturk.com/%0A...` (script on this
    site) and `https://evil.example\\@www.mturk.com/` (a browser posts to evil.example) through:
    browsers parse URLs by the WHATWG rules, which strip tabs and newlines and read backslashes as
    slashes.  So: printable ASCII without backslashes only, https only, no user, password, port,
    path, query or fragment, and the stored value is the allowlisted one, never the raw input."""
    if not raw:
        return ""
    if any(not 0x21 <= ord(c) <= 0x7E or c == "\\" for c in raw):
        raise ValueError(gettext("turkSubmitTo must be a plain https://www.mturk.com address"))
    parts = urlsplit(raw)
    host = parts.netloc.lower()
    if (parts.scheme.lower() != "https" or host not in MTURK_HOSTS or parts.path not in ("", "/")
            or parts.query or parts.fragment):
        raise ValueError(gettext("turkSubmitTo must be https://www.mturk.com or https://workersandbox.mturk.com"))
    return f"https://{host}"


def completion_target(participant: Participant) -> dict:
    """Where a finished or ended participant is sent back to, with their code (only once every answer is
    stored, or their outcome set): Prolific's completion address with the code, or MTurk's submit form."""
    study, code = participant.study, participant.completion_code
    if (participant.completed_at is None and not participant.outcome) or not code:
        return {}
    if participant.platform == Participant.PROLIFIC:
        return {"redirect_url": study.prolific_completion_url.format(code=code)}
    if participant.platform == Participant.MTURK and participant.platform_session_id:
        try:  # checked again: a row stored before the allowlist may hold anything
            site = mturk_submit_base(participant.turk_submit_to)
        except ValueError:
            site = ""
        base = site + "/mturk/externalSubmit" if site else study.mturk_submit_url
        return {"mturk_form": {"action": base, "assignmentId": participant.platform_session_id,
                               "completion_code": code}}
    return {}
