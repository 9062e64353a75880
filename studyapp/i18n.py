"""The language participants read: their study's (Study.language), whatever their browser asks for.

Participant views run inside :func:`in_study_language`, which activates the study's language for the
request (researchers' pages stay in settings.LANGUAGE_CODE).  Every participant-facing string goes through
Django's catalogs: templates by ``{% translate %}``, Python by ``gettext``, JavaScript by the study's
JavaScript catalog (:func:`javascript_catalog`), and a robot's own texts (a domain's ParticipantTexts,
written in English in ``teaching/``, which knows no Django) by :func:`participant_texts`, which looks each
up in the catalog of the active language.
"""
from __future__ import annotations

from dataclasses import replace
from functools import wraps

from django.conf import settings
from django.urls import Resolver404, resolve
from django.utils import translation
from django.utils.translation import gettext
from django.views.i18n import JavaScriptCatalog

from teaching.api import TranslatableError

from .models import Study


def study_language(slug: str) -> str:
    """The language of the study `slug` (the site's default for an unknown slug: its 404 page)."""
    found = Study.objects.filter(slug=slug).values_list("language", flat=True).first()
    return found or settings.LANGUAGE_CODE


# The URL names of the participant pages (studyapp/urls.py): what is refused before their view runs is
# refused in their study's language.
PARTICIPANT_URLS = frozenset({"entry", "step", "answer", "jsi18n"})


def participant_language(request) -> str | None:
    """The study's language when `request` asks for one of its participant pages, from the URL alone;
    None for any other page.  For refusals sent before a view runs (a body too large, incomplete or with
    a NUL): one indexed query by slug, only when refusing."""
    try:
        match = resolve(request.path_info)
    except Resolver404:
        return None
    return study_language(match.kwargs["slug"]) if match.url_name in PARTICIPANT_URLS else None


def in_study_language(view):
    """Run a participant view (its URL names the study's ``slug``) in the study's language; the response
    says which (Content-Language)."""
    @wraps(view)
    def wrapped(request, *args, **kwargs):
        language = study_language(kwargs["slug"])
        with translation.override(language):
            request.LANGUAGE_CODE = language
            response = view(request, *args, **kwargs)
        response.headers.setdefault("Content-Language", language)
        return response

    return wrapped


# The study's JavaScript catalog (gettext() and interpolate() for the participant pages' scripts), in its
# language: a script from this site, so the participant pages' CSP (script-src 'self') allows it.
javascript_catalog = in_study_language(JavaScriptCatalog.as_view(domain="djangojs"))


SOURCE_LANGUAGE = "en"  # the language the domains write their texts in


def _language() -> str:
    return (translation.get_language() or settings.LANGUAGE_CODE).split("-")[0].lower()


def _each_text(texts, look):
    """`texts` (ParticipantTexts) with `look` applied to every text a participant reads; the values stored
    (the attention check's answers, the right choices' indices) unchanged."""
    return replace(
        texts,
        summary=look(texts.summary), consent=look(texts.consent),
        instructions=tuple(look(p) for p in texts.instructions),
        attention_question=look(texts.attention_question),
        attention_choices=tuple((value, look(label)) for value, label in texts.attention_choices),
        watch=look(texts.watch), question=look(texts.question),
        legend=tuple(replace(entry, label=look(entry.label)) for entry in texts.legend),
        option=look(texts.option), choice_required=look(texts.choice_required), title=look(texts.title),
        comprehension=tuple(replace(q, text=look(q.text), choices=tuple(look(c) for c in q.choices))
                            for q in texts.comprehension),
    )


def domain_text(domain, text: str) -> str:
    """One of the domain's texts in the active language: the domain's own translation (a world file's
    [translations.<language>]) first, then the catalog.  A text the domain filled in from its data (a grid
    world's title) is in the catalog as the text it was filled from (the domain's ``formatted_texts``): that
    is translated and filled in with its values, each translated alike."""
    if not text:
        return text
    own = domain.translations.get(_language(), {})
    if text in own:
        return own[text]
    formatted = domain.formatted_texts
    if text in formatted:
        template, values = formatted[text]
        return gettext(template).format(**{k: domain_text(domain, v) for k, v in values.items()})
    return gettext(text)


def participant_texts(domain):
    """The domain's ParticipantTexts in the active language (:func:`domain_text` for each text a
    participant reads); the values stored (the attention check's answers, the right choices' indices)
    unchanged."""
    return _each_text(domain.texts, lambda text: domain_text(domain, text))


def untranslated_texts(domain, language: str) -> list[str]:
    """The domain's texts a participant reading `language` would read in English, in their order: a text
    counts as translated when the domain's own translations have it, or the catalog translates it (or, for
    a text filled in from the domain's data, the text it was filled from, and each value filled in)."""
    if language == SOURCE_LANGUAGE:
        return []
    own = domain.translations.get(language, {})
    formatted = domain.formatted_texts
    missing = []

    def look(text: str) -> str:
        if not text or text in own:
            return text
        if text in formatted:
            template, values = formatted[text]
            for each in (template, *values.values()):
                look(each)
        elif gettext(text) == text:
            missing.append(text)
        return text

    with translation.override(language):
        _each_text(domain.texts, look)
    return list(dict.fromkeys(missing))


def language_problem(domain, language: str) -> str:
    """Why a study of `domain` cannot be in `language` ("" if it can): one line naming the texts its
    participants would read in English, and where to translate them."""
    if language not in dict(settings.LANGUAGES):
        return ""  # not a language of the site: the study's own checks refuse it, saying so
    missing = untranslated_texts(domain, language)
    if not missing:
        return ""
    name = translation.get_language_info(language)["name"]  # in English: a researcher reads it
    shown = ", ".join(repr(t if len(t) <= 60 else t[:57] + "...") for t in missing[:8])
    more = f" and {len(missing) - 8} more" if len(missing) > 8 else ""
    source = domain.translations_source
    where = (f"add them under [translations.{language}] in the world file {source} (docs/gridworlds.md)" if source
             else f"add them to locale/{language}/LC_MESSAGES/django.po (docs/study.md, \"Languages\")")
    return (f"a study in {name} needs every text of the robot {domain.name!r} in {name}, and these have no "
            f"translation: {shown}{more}; {where}")


def translated_error(error) -> str:
    """A refusal the domain raised, in the active language where it can say it (a TranslatableError:
    its message and the words it names through the catalog), else as it was raised."""
    return error.say(gettext) if isinstance(error, TranslatableError) else str(error)
