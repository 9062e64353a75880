"""What a page needs to draw a study's domain: its scene module, palette, legend and texts.

Every page that draws scenes (a participant's training and test steps, the staff stimulus sheet)
gets :func:`scene_context` of its study's domain: the browser loads the generic player
(static/studyapp/player.js), which imports ``static/studyapp/scenes/<scene>.js`` (the domain's
``scene``: its name, or a scene domains share); the domain's
palette is written once into the page as CSS custom properties (``--scene-<name>``), which the
canvas, the legend's swatches and (in Python) the contact sheet all use.
"""
from __future__ import annotations

import mimetypes
import re

from django.http import FileResponse, Http404
from django.templatetags.static import static

from teaching.api import Domain, recording_file

from .i18n import participant_texts
from .trajectories import study_domain

# a palette entry is a hex colour or an rgb()/rgba() one: nothing else reaches the page's <style>
COLOUR = re.compile(r"^(#[0-9a-fA-F]{3,8}|rgba?\(\s*[\d.]+\s*(,\s*[\d.]+\s*){2,3}\))$")
NAME = re.compile(r"^[a-z][a-z0-9-]*$")


def palette_css(domain: Domain) -> str:
    """``:root { --scene-<name>: <colour>; ... }`` of the domain's palette (checked, so a page's
    <style> gets colours and nothing else)."""
    for name, colour in domain.palette.items():
        if not (NAME.match(name) and COLOUR.match(colour)):
            raise ValueError(f"domain {domain.name!r}: palette entry {name!r}: {colour!r} is not a CSS colour")
    return ":root { " + " ".join(f"--scene-{n}: {c};" for n, c in domain.palette.items()) + " }"


def legend(domain: Domain) -> list[dict]:
    """The legend's swatches: label and the CSS of a swatch drawn like the canvas draws that thing."""
    out = []
    for entry in participant_texts(domain).legend:
        style = f"background-color: var(--scene-{entry.fill}); border-color: var(--scene-{entry.edge});"
        if entry.hatch:
            style += (f" background-image: repeating-linear-gradient(-45deg, transparent 0 3px, "
                      f"var(--scene-{entry.hatch}) 3px 5px);")
        out.append({"label": entry.label, "style": style, "letter": entry.letter})
    return out


def scene_context(study, media_base: str = "") -> dict:
    """Template context of a page that draws `study`'s scenes; `media_base`: the URL its recordings are served
    under (a participant's own, or the researchers'), for a robot whose stimuli are recordings."""
    domain = study_domain(study)
    return {"domain": domain.name, "scene_name": domain.scene, "palette_css": palette_css(domain),
            "legend": legend(domain), "scene_module": static(f"studyapp/scenes/{domain.scene}.js"),
            "texts": participant_texts(domain), "scene_view": study.scene_view(), "media_base": media_base}


def recording(study, name: str) -> FileResponse:
    """The recording `name` (an opaque SHA-256 file name, ``teaching.api.stimulus_of``) of `study`'s robot; 404 for
    a name that is not one of its recordings."""
    try:
        domain = study_domain(study)
    except ValueError:  # its robot is not here (Study.running_problems): its pages say so, a file is not found
        raise Http404("no such recording") from None
    path = recording_file(domain, name)
    if path is None or not path.is_file():
        raise Http404("no such recording")
    return FileResponse(path.open("rb"), content_type=mimetypes.guess_type(path.name)[0] or "video/webm")


def instructions(study, n_training: int, n_tests: int) -> list[str]:
    """The domain's instruction paragraphs, filled in for one participant."""
    values = {"n_training": n_training, "n_tests": n_tests, "training_plural": "" if n_training == 1 else "s",
              "tests_plural": "" if n_tests == 1 else "s"}
    return [p.format(**values) for p in participant_texts(study_domain(study)).instructions]
