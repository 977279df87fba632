"""Shell templates under `templates/`, filled by plain `@TOKEN@` substitution."""

from __future__ import annotations

import re
from functools import cache
from pathlib import Path

from wsbuild import inputs
from wsbuild.substitution import TokenError, find_tokens, substitute

TEMPLATE_DIR = Path(__file__).parent / "templates"
_TOKEN = re.compile(r"@([A-Z][A-Z0-9_]*)@")


@cache
def load_template(name: str) -> str:
    """One of wsbuild's templates, read as a declared input (a run that writes setup scripts
    depends on them)."""
    return inputs.read_text(TEMPLATE_DIR / name)


def render(name: str, **values: str) -> str:
    """Fill every `@TOKEN@` of template `name`; a missing or unused value is a bug."""
    text = load_template(name)
    try:
        return substitute(text, values, _TOKEN, use_every_value=True)
    except TokenError:
        raise KeyError(
            f"template {name}: tokens {sorted(find_tokens(text, _TOKEN))} "
            f"but values for {sorted(values)}"
        ) from None
