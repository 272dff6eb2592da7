"""contactrig.core.text: strings from files shown as text — on a terminal, in Markdown, in HTML — never interpreted."""

from __future__ import annotations

import html
import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contactrig.core.text import escape_html, escape_markdown, escape_terminal, markdown_code_block

HOSTILE = [
    "\x1b]0;owned\x07",  # set the window title
    "\x1b[2J\x1b[H",  # clear the screen
    "ok\rFAKE",  # overwrite the line
    "a\x08\x08b",  # backspaces
    "abc\u202edcba",  # bidi override
    "line\nsecond",
    "\x9b31m",  # C1 CSI
]


@pytest.mark.parametrize("text", HOSTILE)
def test_terminal_sees_no_control_character(text):
    out = escape_terminal(text)
    assert not re.search(r"[\x00-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]", out), repr(out)
    assert "\n" not in out


def test_terminal_escapes_are_readable_and_plain_text_is_unchanged():
    assert escape_terminal("R = 8.09 mΩ ± 1 µΩ, 5.44 kg") == "R = 8.09 mΩ ± 1 µΩ, 5.44 kg"
    assert escape_terminal("\x1b[31mred") == "\\x1b[31mred"
    assert escape_terminal("a\nb") == "a\\nb" and escape_terminal("a\nb", keep_newlines=True) == "a\nb"
    assert escape_terminal("x\u202ey") == "x\\u202ey"
    assert escape_terminal(42) == "42"


@pytest.mark.parametrize(
    "text",
    ["# heading", "[link](javascript:alert(1))", "![img](http://x/y.png)", "| a | b |", "`code`", "*bold* _it_",
     "<script>alert(1)</script>", "<img src=x onerror=alert(1)>", "1. item", "- item", "> quote", "a\nb\n# h"],
)  # fmt: skip
def test_markdown_shows_markup_as_text(text):
    out = escape_markdown(text)
    assert "\n" not in out and "<" not in out and ">" not in out
    for active in "|`*()":  # tables, code, emphasis, link targets: escaped wherever they are
        assert re.search(rf"(?<!\\)\{active}", out) is None, (text, out)
    assert re.search(r"(?<!\\)\][(\[:]", out) is None, out  # no "](", "][" or "]:" that closes a link
    assert not re.match(r"\s*([#>+-]|\d+[.)]\s)", out), out  # no heading, quote or list at the start
    assert not re.search(r"(?<![\\\w])_", out), out  # no emphasis by underscores


def test_markdown_leaves_ordinary_text_readable():
    assert escape_markdown("2026-11-24T14:45 paper-default") == "2026-11-24T14:45 paper-default"
    assert escape_markdown("- item") == "\\- item" and escape_markdown("1. first") == "1\\. first"
    assert escape_markdown("ψ = 1.8, [rig] clearance_m = 1e-3 (measured)!") == (
        "ψ = 1.8, [rig] clearance_m = 1e-3 \\(measured\\)!"
    )


@given(st.text())
def test_markdown_escape_keeps_the_text(text):
    """Unescaping what escape_markdown did gives the text back (line breaks as spaces, controls made visible)."""
    out = escape_markdown(text)
    back = html.unescape(re.sub(r"\\(.)", r"\1", out))
    expected = " ".join(escape_terminal(text.replace("\r\n", "\n"), keep_newlines=True).split("\n"))
    assert back == expected


@given(st.text())
def test_html_escape_leaves_no_markup(text):
    out = escape_html(text)
    assert "<" not in out and ">" not in out and '"' not in out and "'" not in out
    assert re.sub(r"&(?!(amp|lt|gt|quot|#x27);)", "", out) == out  # every & starts an entity


def test_html_round_trip_of_plain_text():
    assert html.unescape(escape_html('a < b & "c"')) == 'a < b & "c"'


def test_code_block_cannot_be_closed_by_its_content():
    text = "[rig]\n```\n# not a heading\n````\n"
    block = markdown_code_block(text, "toml")
    fence = block.splitlines()[0].removesuffix("toml")
    assert len(fence) == 5 and block.endswith("\n" + fence)
    assert text.rstrip("\n") in block


# ---------------------------------------------------------------------------------------------- quote (errors)
@settings(max_examples=300, deadline=None)
@given(st.one_of(st.text(max_size=400), st.binary(max_size=400)))
def test_quote_is_short_and_starts_like_the_repr(value):
    from contactrig.core.text import QUOTE_LIMIT, is_path_like, quote

    q = quote(value)
    full = repr(value)
    if len(full) <= QUOTE_LIMIT or is_path_like(value):  # a file path is quoted whole: it names the file
        assert q == full
    else:
        head, _, tail = q.rpartition("…")
        assert len(head) <= QUOTE_LIMIT and full.startswith(head[:-1] if head.endswith(("'", '"')) else head)
        assert tail.endswith(f"({len(value)} {'characters' if isinstance(value, str) else 'bytes'})")


def test_bound_error_line_cuts_long_literals_and_long_words_only_in_long_lines():
    from contactrig.core.text import ERROR_LINE_LIMIT, bound_error_line

    short = "x = 'a b' is not allowed: " + "w" * 100
    assert bound_error_line(short) == short
    line = f"t.csv: row 2, column 'M1' = {'z' * 5000!r} is not allowed; key {'k' * 5000} unknown"
    out = bound_error_line(line)
    assert len(out) <= ERROR_LINE_LIMIT and "(5000 characters)" in out and out.startswith("t.csv: row 2")


def test_a_file_path_is_quoted_whole_and_a_huge_one_is_not():
    from contactrig.core.text import PATH_LIMIT, quote

    path = "/tmp/pytest-of-root/pytest-54/test_load_database_on_damaged_14/sealed-pressure-altered.h5"
    assert quote(path) == repr(path)
    assert len(quote("/" * (PATH_LIMIT + 1))) < 120
