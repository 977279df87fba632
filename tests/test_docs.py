"""README is the door and docs/guide/ the user guide by task: the door stays short, says the
limits of a pip-only machine before anything else, and every link of both leads somewhere."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
README = REPO / "README.md"
GUIDE = REPO / "docs" / "guide"
#: a newcomer reads the door to its end
DOOR_LINES = 150


def _headings(text: str) -> list[str]:
    return [line[3:].strip() for line in text.splitlines() if line.startswith("## ")]


def test_the_readme_is_the_door_with_the_limits_up_front() -> None:
    text = README.read_text()
    assert len(text.splitlines()) <= DOOR_LINES
    headings = _headings(text)
    assert headings[0].startswith("What a pip-only machine cannot do")
    for limit in ("rclcpp", "launch", "ament_copyright"):
        assert limit in text.split("## ")[1], limit
    assert headings.index("Two commands") < headings.index("Installing") < \
        headings.index("Quickstart")
    for command in ("bash scripts/demo.sh", "bash scripts/test.sh",
                    "pip install './wsbuild[ros]'"):
        assert command in text


def test_every_guide_page_is_in_its_contents_and_every_link_leads_somewhere() -> None:
    pages = sorted(p.name for p in GUIDE.glob("*.md") if p.name != "README.md")
    contents = (GUIDE / "README.md").read_text()
    assert [name for name in pages if f"]({name})" not in contents] == []
    broken = []
    for document in (README, *sorted(GUIDE.glob("*.md"))):
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", document.read_text()):
            if "://" not in target and not (document.parent / target).exists():
                broken.append(f"{document.relative_to(REPO)}: {target}")
    assert broken == []
