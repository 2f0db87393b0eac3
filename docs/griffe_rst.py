"""Griffe extension: the reStructuredText parts of numpydoc docstrings, as Markdown.

The docstrings follow numpydoc, which borrows three things from reStructuredText that
Markdown does not know: cross-reference roles (``:func:`normalize```), inline math
(``:math:`E = I / d^2```) and display math (``.. math::`` with an indented block). This
extension rewrites them when mkdocstrings loads the package, so that the API pages link the
names and typeset the equations (MathJax through ``pymdownx.arithmatex``); the source stays
plain numpydoc.

Cross-references become optional autorefs: a link when the target is on a page of the site,
plain code otherwise (names in other packages, private helpers), never a build warning.
"""

from __future__ import annotations

import html
import re
from typing import Any

import griffe

ROLE = re.compile(
    r":(?:py:)?(?P<role>func|class|meth|mod|attr|exc|data|obj|const|math):`(?P<text>[^`]+)`"
)
DIRECTIVE = re.compile(r"^(?P<indent>[ \t]*)\.\. math::[ \t]*(?P<rest>.*)$")
#: Top-level packages whose dotted names are used as written.
PACKAGES = ("nightlights", "ies", "bayesnets", "nightlights_cli")


class ReStructuredTextToMarkdown(griffe.Extension):
    """Rewrite roles and math directives in every docstring of a loaded package."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        for obj in _walk(pkg):
            if obj.docstring is not None:
                obj.docstring.value = docstring_to_markdown(obj.docstring.value, obj)


def _walk(obj: griffe.Object) -> Any:
    yield obj
    for member in obj.members.values():
        if member.is_alias:
            continue
        yield from _walk(member)


def docstring_to_markdown(text: str, obj: griffe.Object | None = None) -> str:
    """Rewrite the math directives, then the roles, of one docstring."""
    return ROLE.sub(lambda match: _role(match, obj), _display_math(text))


def _display_math(text: str) -> str:
    lines = text.splitlines()
    out: list[str] = []
    index = 0
    while index < len(lines):
        match = DIRECTIVE.match(lines[index])
        if match is None:
            out.append(lines[index])
            index += 1
            continue
        indent = match.group("indent")
        body = [match.group("rest").strip()] if match.group("rest").strip() else []
        index += 1
        block: list[str] = []
        while index < len(lines):
            line = lines[index]
            if line.strip() and len(line) - len(line.lstrip()) <= len(indent):
                break
            block.append(line)
            index += 1
        while block and not block[-1].strip():
            block.pop()
        width = min((len(line) - len(line.lstrip()) for line in block if line.strip()), default=0)
        body += [line[width:].rstrip() for line in block]
        body = [line for line in body if line.strip()]
        if out and out[-1].strip():
            out.append("")
        out += [indent + "$$", *(indent + line for line in body), indent + "$$", ""]
    return "\n".join(out)


def _role(match: re.Match[str], obj: griffe.Object | None) -> str:
    role, text = match.group("role"), match.group("text")
    if role == "math":
        return f"${text}$"
    short = text.startswith("~")
    name = text.lstrip("~").removesuffix("()")
    title = name.rsplit(".", 1)[-1] if short else name
    if role in ("func", "meth"):
        title += "()"
    identifier = _identifier(name, obj)
    code = f"<code>{html.escape(title)}</code>"
    if identifier is None:
        return code
    return f'<autoref optional identifier="{html.escape(identifier)}">{code}</autoref>'


def _identifier(name: str, obj: griffe.Object | None) -> str | None:
    if name.split(".", 1)[0] in PACKAGES:
        return name
    if obj is None:
        return None
    first, _, rest = name.partition(".")
    scope: griffe.Object | None = obj
    while scope is not None:
        try:
            path = scope.resolve(first)
        except griffe.NameResolutionError:
            scope = scope.parent
            continue
        return f"{path}.{rest}" if rest else path
    return None
