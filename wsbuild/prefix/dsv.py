"""Reading `.dsv` environment descriptions into resolved operations (colcon's prefix_util semantics)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

from wsbuild.errors import WsbuildError
from wsbuild.prefix.quoting import validate_variable_name


class Action(Enum):
    """What one resolved line does; `prepend-non-duplicate-if-exists` resolves to PREPEND."""

    PREPEND = "prepend-non-duplicate"
    APPEND = "append-non-duplicate"
    SET = "set"
    SET_IF_UNSET = "set-if-unset"
    SOURCE = "source"


DSV_PREPEND_IF_EXISTS = "prepend-non-duplicate-if-exists"
_LIST_TYPES = {Action.PREPEND.value, Action.APPEND.value, DSV_PREPEND_IF_EXISTS}
_SET_TYPES = {Action.SET.value, Action.SET_IF_UNSET.value}


@dataclass(frozen=True, slots=True)
class Operation:
    """One environment change of a package, with paths kept relative to its prefix.

    `relative` means `value` is relative to the package prefix (`""` is the prefix itself);
    otherwise `value` is used literally (an absolute path or a plain `set` value). For
    SOURCE, `value` is the script path without extension and `extensions` the variants the
    package.dsv lists; `script_for` picks the one a shell sources (with
    COLCON_CURRENT_PREFIX set to the prefix).
    """

    action: Action
    name: str
    value: str
    relative: bool
    extensions: tuple[str, ...] = ()

    def script_for(self, shell: str | None) -> str | None:
        """colcon's choice: the `.sh` when it is the only candidate, else the shell's own."""
        candidates = {ext for ext in self.extensions if ext in ("sh", shell)}
        if candidates == {"sh"}:
            return self.value + ".sh"
        if shell is not None and shell in candidates:
            return f"{self.value}.{shell}"
        return None

    def resolve(self, prefix: str) -> str:
        """The value with the prefix filled in, as colcon computes it (`os.path.join`)."""
        if not self.relative:
            return self.value
        return os.path.join(prefix, self.value) if self.value else prefix


@dataclass(frozen=True, slots=True)
class PackageEnvironment:
    """The resolved operations of one package and the `.dsv` files they were read from
    (the package.dsv first, even when it does not exist)."""

    operations: tuple[Operation, ...]
    files: tuple[Path, ...]


def package_dsv_path(prefix: Path, package: str) -> Path:
    return prefix / "share" / package / "package.dsv"


def resolve_package(prefix: Path, package: str) -> PackageEnvironment:
    """Interpret `share/<pkg>/package.dsv` (recursively) as colcon's prefix_util does.

    A `source` line is followed into its `.dsv` sibling when one exists; otherwise the
    script becomes a SOURCE operation listing its variants (see `Operation.script_for`).
    A missing package.dsv yields no operations.
    """
    files: list[Path] = []
    dsv = package_dsv_path(prefix, package)
    if not dsv.is_file():
        # listed anyway, so a cache keyed on these files notices when it appears
        return PackageEnvironment((), (dsv,))
    operations = _process_dsv(dsv, str(prefix), files, ())
    return PackageEnvironment(tuple(operations), tuple(files))


def _process_dsv(dsv: Path, prefix: str, files: list[Path], stack: tuple[Path, ...]) -> list[Operation]:
    if dsv in stack:
        chain = " -> ".join(str(p) for p in (*stack, dsv))
        raise WsbuildError(f"environment descriptions source each other: {chain}", path=dsv)
    files.append(dsv)
    try:
        content = dsv.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise WsbuildError(f"cannot read environment description: {exc}", path=dsv) from exc
    operations: list[Operation] = []
    # colcon applies the non-source lines first, then the sourced files grouped by basename
    basenames: dict[str, set[str]] = {}
    for number, line in enumerate(content.splitlines(), start=1):
        if not line.strip() or line.startswith("#"):
            continue
        type_, sep, remainder = line.partition(";")
        if not sep:
            raise WsbuildError(
                "line has no semicolon separating the type from the arguments",
                path=dsv, line=number,
            )
        if type_ == Action.SOURCE.value:
            base, ext = os.path.splitext(remainder)
            if not ext:
                raise WsbuildError(
                    f"sourced file {remainder!r} has no extension", path=dsv, line=number
                )
            basenames.setdefault(base, set()).add(ext[1:])
        elif type_ in _SET_TYPES:
            operations.extend(_set_line(type_, remainder, prefix, dsv, number))
        elif type_ in _LIST_TYPES:
            operations.extend(_list_line(type_, remainder, prefix, dsv, number))
        else:
            raise WsbuildError(
                f"unknown environment hook type {type_!r}", path=dsv, line=number,
                hint="known types: " + ", ".join(sorted(_LIST_TYPES | _SET_TYPES | {"source"})),
            )
    for base, extensions in basenames.items():
        relative = not os.path.isabs(base)
        absolute = os.path.join(prefix, base) if relative else base
        if os.path.exists(absolute + ".dsv"):
            operations.extend(_process_dsv(Path(absolute + ".dsv"), prefix, files, (*stack, dsv)))
        else:
            variants = tuple(sorted(extensions - {"dsv"}))
            operations.append(Operation(Action.SOURCE, "", base, relative, variants))
    return operations


def _set_line(type_: str, remainder: str, prefix: str, dsv: Path, number: int) -> list[Operation]:
    name, sep, value = remainder.partition(";")
    if not sep:
        raise WsbuildError(
            "line has no semicolon separating the variable name from the value",
            path=dsv, line=number,
        )
    validate_variable_name(name, path=dsv, line=number)
    # colcon uses the prefixed path when it exists, the literal value otherwise
    candidate = os.path.join(prefix, value) if value else prefix
    relative = not os.path.isabs(value) and os.path.exists(candidate)
    return [Operation(Action(type_), name, value, relative)]


def _list_line(type_: str, remainder: str, prefix: str, dsv: Path, number: int) -> list[Operation]:
    name, *values = remainder.split(";")
    validate_variable_name(name, path=dsv, line=number)
    operations = []
    for value in values:
        relative = not os.path.isabs(value)
        if type_ == DSV_PREPEND_IF_EXISTS:
            absolute = (os.path.join(prefix, value) if value else prefix) if relative else value
            if not os.path.exists(absolute):
                continue
        action = Action.APPEND if type_ == Action.APPEND.value else Action.PREPEND
        operations.append(Operation(action, name, value, relative))
    return operations
