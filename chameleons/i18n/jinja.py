"""Jinja2's i18n extension with the language chosen per page, not per process.

A page passes ``language`` in its template context (the phone pages pass the session's
language); ``_()``, ``gettext`` and ``{% trans %}`` then use that language's catalogue.
Pages without one (the staff pages) get English. Newstyle gettext: ``_("Hi %(name)s",
name=x)`` formats and escapes like ``{% trans %}``.
"""

from __future__ import annotations

from typing import Any

from jinja2 import Environment, pass_context
from jinja2.runtime import Context
from markupsafe import Markup

from chameleons.i18n import SOURCE_LANGUAGE, text_direction, translations


def _language(context: Context) -> str:
    return str(context.get("language") or SOURCE_LANGUAGE)


@pass_context
def _gettext(context: Context, message: str, **variables: Any) -> str:
    text = translations(_language(context)).gettext(message)
    if context.eval_ctx.autoescape:
        text = Markup(text)  # noqa: S704 - our catalogue; Markup makes % escape the values
    return text % variables


@pass_context
def _ngettext(context: Context, singular: str, plural: str, number: int, **variables: Any) -> str:
    variables.setdefault("num", number)
    text = translations(_language(context)).ngettext(singular, plural, number)
    if context.eval_ctx.autoescape:
        text = Markup(text)  # noqa: S704 - our catalogue; Markup makes % escape the values
    return text % variables


@pass_context
def _direction(context: Context) -> str:
    return text_direction(_language(context))


def install(env: Environment) -> None:
    env.add_extension("jinja2.ext.i18n")
    env.globals.update(gettext=_gettext, ngettext=_ngettext, text_direction=_direction)
    env.newstyle_gettext = True  # type: ignore[attr-defined]
