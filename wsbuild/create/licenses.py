"""The SPDX license ids `pkg create` writes a LICENSE file for, and checks of license strings."""

from __future__ import annotations

from dataclasses import dataclass

from wsbuild.patterns import lazy


@dataclass(frozen=True, slots=True)
class License:
    """A license `pkg create` knows: SPDX id, name, and its text under templates/licenses/."""

    spdx: str
    title: str
    #: file stem under templates/licenses/ (several ids share a text, e.g. -only and -or-later)
    text: str


LICENSES: tuple[License, ...] = (
    License("Apache-2.0", "Apache License 2.0", "Apache-2.0"),
    License("BSD-2-Clause", 'BSD 2-Clause "Simplified" License', "BSD-2-Clause"),
    License("BSD-3-Clause", 'BSD 3-Clause "New" or "Revised" License', "BSD-3-Clause"),
    License("BSL-1.0", "Boost Software License 1.0", "BSL-1.0"),
    License("GPL-2.0-only", "GNU General Public License v2.0 only", "GPL-2.0"),
    License("GPL-2.0-or-later", "GNU General Public License v2.0 or later", "GPL-2.0"),
    License("GPL-3.0-only", "GNU General Public License v3.0 only", "GPL-3.0"),
    License("GPL-3.0-or-later", "GNU General Public License v3.0 or later", "GPL-3.0"),
    License("LGPL-2.1-only", "GNU Lesser General Public License v2.1 only", "LGPL-2.1"),
    License("LGPL-2.1-or-later", "GNU Lesser General Public License v2.1 or later", "LGPL-2.1"),
    License("LGPL-3.0-only", "GNU Lesser General Public License v3.0 only", "LGPL-3.0"),
    License("LGPL-3.0-or-later", "GNU Lesser General Public License v3.0 or later", "LGPL-3.0"),
    License("MIT", "MIT License", "MIT"),
    License("MPL-2.0", "Mozilla Public License 2.0", "MPL-2.0"),
)

#: what `ros2 pkg create` writes when no license is given; not an SPDX id, and no LICENSE file
NO_LICENSE = "TODO: License declaration"

_BY_ID = {entry.spdx: entry for entry in LICENSES}
_BY_FOLDED = {entry.spdx.lower(): entry for entry in LICENSES}

# Names people write instead of an SPDX id (keys: lowercase, only letters, digits, '.', '+').
_ALIASES: dict[str, str] = {
    "apache": "Apache-2.0",
    "apache2": "Apache-2.0",
    "apache20": "Apache-2.0",
    "apache2.0": "Apache-2.0",
    "apachev2.0": "Apache-2.0",
    "apachev2": "Apache-2.0",
    "apachelicense2.0": "Apache-2.0",
    "apachelicense20": "Apache-2.0",
    "apachelicenseversion2.0": "Apache-2.0",
    "asl2.0": "Apache-2.0",
    "mitlicense": "MIT",
    "expat": "MIT",
    "bsd": "BSD-3-Clause",
    "bsd3": "BSD-3-Clause",
    "bsd3clause": "BSD-3-Clause",
    "newbsd": "BSD-3-Clause",
    "bsd2": "BSD-2-Clause",
    "bsd2clause": "BSD-2-Clause",
    "simplifiedbsd": "BSD-2-Clause",
    "boost": "BSL-1.0",
    "bsl": "BSL-1.0",
    "mpl": "MPL-2.0",
    "mpl2": "MPL-2.0",
    "gpl": "GPL-3.0-only or GPL-3.0-or-later",
    "gpl3": "GPL-3.0-only or GPL-3.0-or-later",
    "gplv3": "GPL-3.0-only or GPL-3.0-or-later",
    "gpl3.0": "GPL-3.0-only or GPL-3.0-or-later",
    "gpl3.0+": "GPL-3.0-or-later",
    "gplv3+": "GPL-3.0-or-later",
    "gpl2": "GPL-2.0-only or GPL-2.0-or-later",
    "gplv2": "GPL-2.0-only or GPL-2.0-or-later",
    "gpl2.0": "GPL-2.0-only or GPL-2.0-or-later",
    "gpl2.0+": "GPL-2.0-or-later",
    "gplv2+": "GPL-2.0-or-later",
    "lgpl": "LGPL-3.0-only or LGPL-3.0-or-later",
    "lgpl3": "LGPL-3.0-only or LGPL-3.0-or-later",
    "lgplv3": "LGPL-3.0-only or LGPL-3.0-or-later",
    "lgpl3.0": "LGPL-3.0-only or LGPL-3.0-or-later",
    "lgpl3.0+": "LGPL-3.0-or-later",
    "lgpl2.1": "LGPL-2.1-only or LGPL-2.1-or-later",
    "lgplv2.1": "LGPL-2.1-only or LGPL-2.1-or-later",
    "lgpl2.1+": "LGPL-2.1-or-later",
}

_NOT_KEY_CHARS = lazy(r"[^a-z0-9.+]")
# An SPDX license id (or LicenseRef-…), and expressions joining them with AND/OR/WITH.
_SPDX_ID = lazy(r"[A-Za-z0-9][A-Za-z0-9.+-]*")
_EXPRESSION_TOKEN = lazy(r"\s*(\(|\)|[A-Za-z0-9][A-Za-z0-9.+-]*)")


def find_license(spdx: str) -> License | None:
    """The known license with exactly this SPDX id, if any."""
    return _BY_ID.get(spdx)


def canonical_license(text: str) -> tuple[str, str | None]:
    """(license to write, problem): the canonical spelling of `text` and None if it is usable,
    else (text, what to use instead).

    Known ids in another letter case are corrected (SPDX ids are case-insensitive); common
    non-SPDX names ("BSD", "GPLv3", "Apache 2.0") and deprecated ids ("GPL-3.0") get a
    suggestion; any other SPDX-shaped id or expression is accepted as it is.
    """
    stripped = text.strip()
    known = _BY_FOLDED.get(stripped.lower())
    if known is not None:
        return known.spdx, None
    alias = _ALIASES.get(_NOT_KEY_CHARS.sub("", stripped.lower()))
    if alias is not None:
        return stripped, alias
    if stripped == NO_LICENSE or is_spdx_expression(stripped):
        return stripped, None
    return stripped, "an SPDX license id such as Apache-2.0, BSD-3-Clause or MIT"


def is_spdx_expression(text: str) -> bool:
    """True for an SPDX id or an expression like `Apache-2.0 OR MIT` (syntax only)."""
    position, depth, expect_id = 0, 0, True
    while position < len(text):
        match = _EXPRESSION_TOKEN.match(text, position)
        if match is None:
            return text[position:].strip() == "" and not expect_id and depth == 0
        token = match.group(1)
        position = match.end()
        if token == "(":
            if not expect_id:
                return False
            depth += 1
        elif token == ")":
            if expect_id or depth == 0:
                return False
            depth -= 1
        elif token in ("AND", "OR", "WITH"):
            if expect_id:
                return False
            expect_id = True
        else:
            if not expect_id or not _SPDX_ID.fullmatch(token):
                return False
            expect_id = False
    return not expect_id and depth == 0
