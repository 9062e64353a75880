"""A robot's texts in the language participants read (their study's, Study.language).

A robot's own texts (a domain's ParticipantTexts, written in English in ``teaching/``, which knows no
Django) are looked up in the catalog of the active language by :func:`participant_texts`; a world file's
own translations come first (:func:`domain_text`).  :func:`language_problem` says which texts a study in
a language would show in English.  Which language a request is in is studyapp.language's.
"""
from __future__ import annotations

from dataclasses import replace

from django.conf import settings
from django.utils import translation
from django.utils.translation import gettext

from teaching.api import TranslatableError

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
