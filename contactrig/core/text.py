"""Strings from files are data: escaping for the places they are shown (Markdown, HTML, a terminal).

Operator, sample, scene text, instrument replies, stop reasons, paths — anything read from a session, sweep or
database file (or typed by someone else) may hold markup, links, script, or terminal control sequences. Wherever
such a string is shown it goes through one of these, so it is displayed as the text it is and never interpreted:

- :func:`escape_terminal` — control characters (ESC sequences that move the cursor, retitle the window or
  rewrite earlier lines, carriage returns, backspaces, bidi overrides) become visible ``\\x1b``-style escapes;
  newlines too unless ``keep_newlines``, so a one-line message stays one line.
- :func:`escape_markdown` — Markdown's active characters are backslash-escaped, HTML is entity-escaped (Markdown
  renderers pass raw HTML through) and line breaks become spaces, so the text cannot open a heading, a table
  cell, a link, an image or a code span; :func:`markdown_code_block` for multi-line text (a scene file).
- :func:`escape_html` — ``& < > " '`` as entities, control characters dropped to visible escapes.
- :func:`shown` — text that is not valid Unicode (the lone surrogates by which Python keeps the bytes of a file name or
  an argument that are not UTF-8, ``name-\xff.h5`` → ``'name-\udcff'``) with those characters as visible escapes
  (``name-\\xff.h5``), so the text can be written to a UTF-8 file, a figure or a page; every ``escape_*`` does the
  same. :func:`check_text` refuses such text where it is typed as content (a sample, an operator, notes).
- :func:`quote` — a value as an error message shows it: its ``repr``, at most :data:`QUOTE_LIMIT` characters of it
  (a 131 072-character table cell is quoted by its first characters and its length); :func:`bound_error_line` is
  the same rule applied to a finished message (the top-level error printer's safety net).
"""

from __future__ import annotations

import html
import os
import re
import unicodedata
from typing import TypeVar

_T = TypeVar("_T")

__all__ = [
    "QUOTE_LIMIT",
    "bound_error_line",
    "check_text",
    "escape_html",
    "escape_markdown",
    "escape_terminal",
    "is_path_like",
    "markdown_code_block",
    "quote",
    "shorten",
    "shown",
]

#: At most this many characters of an offending value are quoted in an error line.
QUOTE_LIMIT = 80
#: An error line longer than this has its long quoted literals cut to QUOTE_LIMIT (and is then cut to ERROR_LINE_LIMIT).
ERROR_LINE_LIMIT = 400

# C0 and C1 controls (without \n, handled apart), DEL, and the Unicode format characters that reorder or hide text
# (bidi overrides and isolates, zero-width joiners): "Trojan source" tricks in a terminal or a rendered report.
_BIDI = "\u061c\u200b\u200c\u200d\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069\ufeff"
# Lone surrogates (U+D800…U+DFFF) are not text: Python holds the undecodable bytes of file names and arguments as
# U+DC80…U+DCFF ("surrogateescape"), and no UTF-8 file, figure or page can take them.
_SURROGATES = "\ud800-\udfff"
_SURROGATE = re.compile(f"[{_SURROGATES}]")
_CONTROL = re.compile(f"[\x00-\x09\x0b-\x1f\x7f-\x9f{_BIDI}\u2028\u2029{_SURROGATES}]")
# Characters with an inline meaning anywhere: code spans, emphasis, tables, strikethrough, math, attributes and the
# parentheses of link targets ("-" makes lists, rules and setext headings only at the start of a line, and the text
# is one line here: handled by the line-start rule; table rules need "|", which is escaped); "]" where
# it could close a link, an image or a reference definition ("](", "][", "]:" — so "[rig]" stays readable); "_" only
# where it can open or close emphasis (snake_case stays readable); and the block markers that count only at the start
# of a line (heading, quote, list, rule).
_MARKDOWN_INLINE = re.compile(r"([\\`*|~$<>{}()])|\](?=[(\[:])|(?<![0-9A-Za-z])_|_(?![0-9A-Za-z])")
_MARKDOWN_LINE_START = re.compile(r"^(\s*)([#+=-])|^(\s*\d+)([.)])(?=\s|$)")


def _visible(match: re.Match[str]) -> str:
    ch = match.group(0)
    code = ord(ch)
    if 0xDC80 <= code <= 0xDCFF:  # an undecodable byte kept by surrogateescape: shown as that byte
        return f"\\x{code - 0xDC00:02x}"
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def shown(value: object) -> str:
    """``value`` as text any UTF-8 file, figure or page takes: lone surrogates (the bytes of a file name or an
    argument that are not UTF-8) become visible escapes — the byte as ``\\xNN`` (``name-\\xff.h5``), other lone
    surrogates as ``\\uNNNN``; everything else is unchanged."""
    text = _str(value)
    return _SURROGATE.sub(_visible, text) if _SURROGATE.search(text) else text


def check_text(field: str, value: _T) -> _T:
    """``value`` itself, or a :class:`~contactrig.core.validation.SettingError` naming ``field`` when it is text
    holding characters that are not valid Unicode (bytes a UTF-8 terminal did not send as UTF-8, e.g. ``Kolben-\\xd8``
    typed on a Latin-1 terminal): such text is refused where it is typed, never stored."""
    if not isinstance(value, str):
        return value
    m = _SURROGATE.search(value)
    if m is None:
        return value
    from contactrig.core.validation import SettingError

    code = ord(m.group(0))
    what = f"byte 0x{code - 0xDC00:02x}" if 0xDC80 <= code <= 0xDCFF else f"lone surrogate U+{code:04X}"
    raise SettingError(
        field, value, f"text in UTF-8 ({what} at character {m.start() + 1} is not UTF-8: set the terminal "
        "or the file to UTF-8 and type it again)"
    )  # fmt: skip


def _str(value: object) -> str:
    return value if isinstance(value, str) else str(value)


def escape_terminal(value: object, *, keep_newlines: bool = False) -> str:
    """``value`` as text safe to print on a terminal: no control character reaches it (each becomes ``\\xNN``).

    Newlines become ``\\n`` too unless ``keep_newlines`` (then a ``\\r`` before them still shows)."""
    text = _CONTROL.sub(_visible, _str(value))
    if not keep_newlines:
        text = text.replace("\n", "\\n")
    return text


def escape_html(value: object) -> str:
    """``value`` as HTML text (element content or a quoted attribute value): markup shows as text."""
    return html.escape(_CONTROL.sub(_visible, _str(value)), quote=True)


def escape_markdown(value: object) -> str:
    """``value`` as inline Markdown text (a paragraph, a list item, a table cell): shown literally.

    Line breaks become spaces (a table row or list item stays one line); ``&`` and ``<`` become HTML entities (no
    raw HTML, no autolink); the characters with an inline meaning (``\\ ` * | ~ $ { } ( )``, ``]`` before ``( [ :``
    and ``_`` outside a word) are backslash-escaped, and so is a block marker at the start (``#``, ``>``, ``-``,
    ``+``, ``=``, ``1.``). No link, image, emphasis, code span, table cell or HTML can come out of it."""
    text = _CONTROL.sub(_visible, _str(value).replace("\r\n", "\n"))
    text = " ".join(text.split("\n"))
    text = _MARKDOWN_INLINE.sub(lambda m: "\\" + m.group(0), text)
    text = text.replace("&", "&amp;").replace("\\<", "&lt;").replace("\\>", "&gt;")
    return _MARKDOWN_LINE_START.sub(_escape_marker, text, count=1)


def _escape_marker(m: re.Match[str]) -> str:
    lead, marker = (m.group(1), m.group(2)) if m.group(2) is not None else (m.group(3), m.group(4))
    return f"{lead}\\{marker}"


def markdown_code_block(value: object, info: str = "text") -> str:
    """Multi-line text (a scene file) as a fenced Markdown code block whose fence the text cannot close."""
    text = _CONTROL.sub(_visible, _str(value).replace("\r\n", "\n"))
    text = unicodedata.normalize("NFC", text)
    longest = max((len(m) for m in re.findall(r"`+|~+", text)), default=0)
    fence = "`" * max(3, longest + 1)
    return f"{fence}{info}\n{text}\n{fence}"


#: A file path is quoted whole up to this length (Linux PATH_MAX): it names the file the error is about.
PATH_LIMIT = 4096


def is_path_like(value: object) -> bool:
    """``value`` is (or reads as) a file path: an ``os.PathLike``, or a string with a ``/`` (or the platform's
    separator), no control character and at most :data:`PATH_LIMIT` characters."""
    if isinstance(value, os.PathLike):
        return True
    return (
        isinstance(value, str)
        and 0 < len(value) <= PATH_LIMIT
        and (os.sep in value or "/" in value)
        and not _CONTROL.search(value)
    )


def quote(value: object, limit: int = QUOTE_LIMIT) -> str:
    """``repr(value)`` as an error message quotes it: whole when it has at most ``limit`` characters (or is a file
    path, see :func:`is_path_like`: the error must name the file), else its first characters, ``…`` and the length
    (``'aaaa…' (131072 characters)``), so a huge input never makes a huge line."""
    text = repr(value)
    if len(text) <= limit or is_path_like(value):
        return text
    if isinstance(value, (str, bytes)):
        head = _repr_head(text, limit - 2)
        what = "characters" if isinstance(value, str) else "bytes"
        return f"{head}…{text[-1]} ({len(value)} {what})"
    return shorten(text, limit)


# One character of a repr body: an escape sequence (kept whole) or a plain character.
_REPR_TOKEN = re.compile(r"\\(?:x[0-9a-fA-F]{2}|u[0-9a-fA-F]{4}|U[0-9a-fA-F]{8}|.)|.", re.DOTALL)


def _repr_head(text: str, limit: int) -> str:
    """The start of the repr ``text`` (prefix and opening quote included) in at most ``limit`` characters, never cut
    inside an escape sequence: a true prefix of ``text`` in the same quoting style."""
    start = text.index(text[-1]) + 1  # after b' / ' / "
    end = start
    for m in _REPR_TOKEN.finditer(text, start, len(text) - 1):
        if m.end() > limit:
            break
        end = m.end()
    return text[:end]


def shorten(text: str, limit: int = QUOTE_LIMIT) -> str:
    """``text`` itself when it has at most ``limit`` characters, else its start, ``…`` and its length."""
    return text if len(text) <= limit else f"{text[: limit - 1]}… ({len(text)} characters)"


# A Python string literal as repr() writes it (the offending values of our messages are quoted this way).
_LITERAL = re.compile(r"'(?:[^'\\\n]|\\.)*'|\"(?:[^\"\\\n]|\\.)*\"")


def bound_error_line(text: str, limit: int = ERROR_LINE_LIMIT) -> str:
    """An error line of at most about ``limit`` characters: every quoted literal longer than :data:`QUOTE_LIMIT`
    is cut as :func:`quote` cuts it, and what is still too long loses its middle (with the count left out)."""
    if len(text) <= limit:
        return text
    text = _LITERAL.sub(_cut_literal, text)
    if len(text) > limit:  # an unquoted name or value (a key, an argument) longer than any word
        text = _LONG_WORD.sub(lambda m: m.group(0) if is_path_like(m.group(0)) else shorten(m.group(0)), text)
    if len(text) <= limit:
        return text
    keep = (limit - 40) // 2
    return f"{text[:keep]} … ({len(text) - 2 * keep} characters left out) … {text[-keep:]}"


_LONG_WORD = re.compile(f"[^\\s'\"]{{{QUOTE_LIMIT + 1},}}")


def _cut_literal(m: re.Match[str]) -> str:
    lit = m.group(0)
    if len(lit) <= QUOTE_LIMIT or is_path_like(lit[1:-1]):
        return lit
    q = lit[0]
    return f"{lit[: QUOTE_LIMIT - 2]}…{q} ({len(lit) - 2} characters)"
