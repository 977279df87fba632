"""Small pieces of English for messages: counted nouns and text cut to a width."""

from __future__ import annotations

from collections.abc import Iterable

#: how much of a quoted line or message a one-line report shows
SHORT_WIDTH = 200


def plural(count: int, word: str, many: str | None = None) -> str:
    """`1 package`, `2 packages`, `0 tests`: the count and the noun, an `s` unless one (`many`:
    the plural when it is not `word` + s, e.g. `entries`)."""
    if count == 1:
        return f"{count} {word}"
    return f"{count} {many if many is not None else word + 's'}"


def shorten(text: str, width: int = SHORT_WIDTH) -> str:
    """`text` unchanged when it fits in `width` characters, else cut so that it fits with a
    trailing `...`."""
    return text if len(text) <= width else text[: width - 3] + "..."


def close_to(word: str, choices: Iterable[str], n: int = 1, cutoff: float = 0.6) -> list[str]:
    """The `n` choices closest to a misspelt `word` (`--packages-selct` → `--packages-select`),
    best first; none when nothing is as close as `cutoff` (difflib's ratio, 1 for equal)."""
    import difflib

    return difflib.get_close_matches(word, list(choices), n=n, cutoff=cutoff)


def did_you_mean(word: str, choices: Iterable[str], n: int = 1) -> str:
    """`did you mean 'std_msgs'?` for a misspelt `word`, "" when no choice is close."""
    close = close_to(word, choices, n)
    return ("did you mean " + " or ".join(f"'{c}'" for c in close) + "?") if close else ""
