"""Text that is safe to print: no terminal escapes, control characters or lone surrogates.

Kept free of NumPy and OpenCV so that the command line can use it on every path (even
``--help`` and usage errors) without importing them.

>>> clean_text("mug\\x1b[31m red")
'mug\\\\x1b[31m red'
"""

from __future__ import annotations

import re

from scenespeak import limits as _limits
from scenespeak.errors import InputError

__all__ = ["check_label", "clean_text"]

_UNSAFE = re.compile(
    "[\x00-\x08\x0b-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069\ud800-\udfff]"
)


def clean_text(text: str, *, keep_newlines: bool = False) -> str:
    """Show control characters, escape sequences and lone surrogates as visible escapes.

    Tabs are kept; newlines only with ``keep_newlines`` (an error message is always one line).
    Bidirectional overrides (``U+202E`` …) are escaped too: they can make a label read as
    something else.

    >>> clean_text("a\\nb")
    'a\\\\nb'
    >>> clean_text("a\\nb", keep_newlines=True)
    'a\\nb'
    >>> clean_text("\\udcff")
    '\\\\udcff'
    """

    def esc(m: re.Match[str]) -> str:
        ch = m.group()
        if ch == "\n" and keep_newlines:
            return ch
        code = ord(ch)
        if ch == "\n":
            return "\\n"
        if ch == "\r":
            return "\\r"
        return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"

    if "\n" in text and not keep_newlines:
        text = text.replace("\n", "\\n")
    return _UNSAFE.sub(esc, text)


def check_label(label: object, source: str = "--label") -> str:
    """An object label as given, or :class:`InputError` saying why it cannot be one.

    Labels are printed in sentences, lists and figures, so they must be printable text: not
    empty, no control characters or escape sequences, no line breaks, no unpaired surrogates,
    no bidirectional overrides, at most :attr:`~scenespeak.limits.Limits.max_label_chars`.

    >>> check_label("red mug")
    'red mug'
    >>> check_label("\x1b[2Jmug")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    scenespeak.errors.InputError: --label: '\\x1b[2Jmug' contains control characters ...
    """
    if not isinstance(label, str):
        raise InputError(source, f"a label must be text, got {type(label).__name__}")
    if not label.strip():
        raise InputError(source, "a label must not be empty")
    limit = _limits.current().max_label_chars
    if len(label) > limit:
        raise InputError(
            source, _limits.exceeded("max_label_chars", f"a label of {len(label)} characters", 0)
        )
    if _UNSAFE.search(label) or "\n" in label or "\t" in label:
        shown = clean_text(repr(label)[:80])
        raise InputError(
            source,
            f"{shown} contains control characters or escape sequences; a label must be "
            "printable text",
        )
    return label
