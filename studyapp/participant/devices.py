"""Which devices may take part in a study (Study.min_screen_width, allow_phones, allow_tablets).

A study whose animations need a desktop screen says so.  The consent page reads the screen in the browser
(static/studyapp/device.js: its width in CSS pixels and whether it is a phone, a tablet or a computer) and
tells a participant who cannot take part why, before they agree.  The server checks what the browser
reported when consent is posted, and also reads the browser's own User-Agent, which says "Mobile" on
phones: a participant it refuses is deleted as one who declines is, so no place is kept for them, and
the study counts the refusal (Study.device_refusals, on the dashboard).
"""
from __future__ import annotations

import re

from django.db.models import F
from django.utils.translation import gettext
from django.utils.translation import gettext_lazy as _

from ..guards.inputs import parse_whole
from ..models import Study

DEVICES = ("computer", "tablet", "phone")
# phones' browsers say "Mobile" (Android, iOS) or "Mobi"; tablets' do not (an iPad says "iPad" or passes as a Mac)
_PHONE_AGENT = re.compile(r"Mobi|iPhone|iPod|Windows Phone", re.I)
NEEDS_SCRIPT = _("This study checks that your screen can show its animations, which needs JavaScript: please turn "
                 "it on and reload the page.")


def rules(study: Study) -> dict:
    """What the consent page's script checks (its data block), with the messages it shows, in the same
    words as the server's (``{width}`` stands for the width it measured)."""
    return {"min_width": study.min_screen_width, "phones": study.allow_phones, "tablets": study.allow_tablets,
            "messages": {"phone": _refused(study, "phone"), "tablet": _refused(study, "tablet"),
                         "width": _too_narrow(study, "{width}")}}


class ReportError(ValueError):
    """A consent post whose device fields no page of the study sends (a width that is not 1 to
    inputs.MAX_DIGITS ASCII digits, a device not in DEVICES): tampered, refused before anything is stored."""


def problem(study: Study, reported, user_agent: str = "") -> str | None:
    """Why this participant's device cannot take part in `study` (a message in their words), or None.

    reported: the consent form's fields, ``screen_width`` (whole CSS pixels) and ``device`` (DEVICES), as
    the page's script filled them, both empty where the script did not run; a User-Agent that names a phone
    makes the device a phone whatever the page reported.  ReportError for fields the script never sends."""
    if not study.has_device_rules:
        return None
    width, device = str(reported.get("screen_width", "")).strip(), str(reported.get("device", "")).strip()
    if not width or not device:
        return str(NEEDS_SCRIPT)
    pixels = parse_whole(width)
    if pixels is None or device not in DEVICES:
        raise ReportError(f"device fields no page sends: screen_width={width[:20]!r}, device={device[:20]!r}")
    if _PHONE_AGENT.search(user_agent or ""):
        device = "phone"
    if device == "phone" and not study.allow_phones:
        return _refused(study, "phone")
    if device == "tablet" and not study.allow_tablets:
        return _refused(study, "tablet")
    if pixels < study.min_screen_width:
        return _too_narrow(study, pixels)
    return None


def _refused(study: Study, device: str) -> str:
    # one whole sentence per device: German gives each its own article ("einem Smartphone", "einem Tablet")
    refused = (gettext("This study cannot be done on a phone: {elsewhere}") if device == "phone"
               else gettext("This study cannot be done on a tablet: {elsewhere}"))
    return refused.format(elsewhere=_elsewhere(study))


def _too_narrow(study: Study, width) -> str:
    return gettext("This study needs a screen at least {min_width} pixels wide, and yours is {width}: "
                   "{elsewhere}").format(min_width=study.min_screen_width, width=width, elsewhere=_elsewhere(study))


def _elsewhere(study: Study) -> str:
    if study.allow_tablets:
        return gettext("please take part on a computer or a tablet instead (on Prolific, please return the study).")
    return gettext("please take part on a computer instead (on Prolific, please return the study).")


def count_refusal(study: Study) -> None:
    Study.objects.filter(pk=study.pk).update(device_refusals=F("device_refusals") + 1)
