"""Reading the elements of one package.xml: errors and warnings that name the file and line,
text-only elements, unknown attributes, REP 149 conditions."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from lxml import etree

from wsbuild.errors import ConditionError, ManifestError
from wsbuild.workspace.condition import evaluate_condition


class ElementReader:
    """One manifest being read: where it is, the environment its conditions see, where its
    warnings go, and its package format (1 until the root says otherwise)."""

    __slots__ = ("path", "environ", "warnings", "format", "refused")

    def __init__(
        self, path: Path, environ: Mapping[str, str], warnings: list[str] | None
    ) -> None:
        self.path = path
        self.environ = environ
        self.warnings = warnings
        self.format = 1
        #: (line, problem, fix) of what catkin_pkg refuses (workspace/model.py's `refused`)
        self.refused: list[tuple[int, str, str]] = []

    def warn(self, line: int | None, message: str) -> None:
        if self.warnings is not None:
            self.warnings.append(f"{self.path}:{line or 1}: {message}")

    def refuse(self, line: int | None, problem: str, fix: str, warning: str = "") -> None:
        """A problem wsbuild reads past (a warning: `warning`, else the problem "ignored")
        that catkin_pkg, which ament_cmake reads package.xml with, refuses."""
        self.warn(line, warning or f"{problem} ignored")
        self.refused.append((line or 1, problem, fix))

    def error(self, message: str, line: int | None, hint: str) -> ManifestError:
        return ManifestError(message, path=self.path, line=line or 1, hint=hint)

    def condition(self, element: etree._Element, expr: str) -> bool:
        try:
            return evaluate_condition(expr, self.environ)
        except ConditionError as exc:
            raise ConditionError(
                f"<{element.tag}> has an invalid condition: {exc.message}",
                path=self.path,
                line=element.sourceline or 1,
                hint=exc.hint,
            ) from None

    def text_of(self, element: etree._Element) -> str:
        if len(element):
            child = element[0]
            found = f"<{child.tag}>" if isinstance(child.tag, str) else "markup"
            raise self.error(
                f"<{element.tag}> must contain only text, found {found}",
                element.sourceline,
                f"remove the markup inside <{element.tag}>",
            )
        text = element.text
        return text.strip() if text else ""

    def check_attributes(self, element: etree._Element, allowed: frozenset[str]) -> None:
        for key in element.keys():
            if key not in allowed and key[0] != "{":  # namespaced (xsi:...) attributes are fine
                known = " or ".join(repr(k) for k in sorted(allowed)) if allowed else "none"
                self.refuse(element.sourceline, f"unknown attribute {key!r} on <{element.tag}>",
                            f"remove it: <{element.tag}> takes {known}")

    def single(self, elements: list[etree._Element], tag: str) -> None:
        if len(elements) > 1:
            raise self.error(
                f"more than one <{tag}> (the first is on line {elements[0].sourceline})",
                elements[1].sourceline,
                f"keep exactly one <{tag}>",
            )
