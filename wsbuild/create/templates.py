"""`pkg create`'s templates: the logic-free variant folders of templates/pkg/, loaded, chosen for
a request and rendered in memory (nothing is written here; `writing` does that).

templates/README.md describes the folders and the token syntax; the substitution itself is
`wsbuild.substitution`'s, with `@name@` tokens and whole-line slots.
"""

from __future__ import annotations

import datetime
import os
import re
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from xml.sax.saxutils import escape

from wsbuild.create.licenses import find_license
from wsbuild.create.validation import PackageCreateError, PackageRequest, check_request
from wsbuild.errors import TemplateError
from wsbuild.substitution import UnknownToken, substitute

#: `@name@`: lowercase, so CMake's own `@VAR@` placeholders (uppercase) pass through untouched
TOKEN = re.compile(r"@([a-z][a-z0-9_]*)@")
TEMPLATE_SUFFIX = ".tmpl"
BASE_VARIANT = "base"
DEPENDENCY_VARIANT = "dependency"
#: option variants in the order their fragments are composed, with the option selecting each
OPTION_VARIANTS: tuple[tuple[str, str], ...] = (
    ("library", "--library-name"),
    ("node", "--node-name"),
    ("launch", "--launch"),
)
DEFAULT_VERSION = "0.0.0"


@dataclass(frozen=True, slots=True)
class RenderedPackage:
    """A package rendered in memory: relative path → content."""

    name: str
    build_type: str
    variants: tuple[str, ...]
    files: tuple[tuple[PurePosixPath, str], ...]
    notes: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class Variant:
    """One template folder: files to create and fragments for slots."""

    name: str
    path: Path
    files: tuple[tuple[PurePosixPath, Path], ...]
    fragments: tuple[tuple[str, Path], ...]


# ------------------------------------------------------------------------------ templates


def templates_root() -> Path:
    """The `templates/` folder: `wsbuild/templates` in a wheel, the repository's top-level
    `templates/` in a source checkout or editable install."""
    here = Path(__file__).resolve().parent
    for candidate in (here.parent / "templates", here.parent.parent / "templates"):
        if (candidate / "pkg").is_dir():
            return candidate
    raise TemplateError("the pkg create templates are missing", path=here.parent / "templates",
                        hint="reinstall wsbuild: its wheel ships them in wsbuild/templates")


def available_build_types(root: Path | None = None) -> tuple[str, ...]:
    """Build types that have a template folder, sorted."""
    pkg = (root or templates_root()) / "pkg"
    return tuple(sorted(p.name for p in pkg.iterdir() if (p / BASE_VARIANT).is_dir()))


def load_variant(folder: Path) -> Variant:
    """Read one variant folder (`files/`, `slots/`); anything else in it is an error."""
    for entry in sorted(os.listdir(folder)):
        if entry not in ("files", "slots"):
            raise TemplateError(f"unexpected {entry!r} in a template folder", path=folder / entry,
                                hint="a variant folder holds only files/ and slots/")
    files: list[tuple[PurePosixPath, Path]] = []
    root = folder / "files"
    if root.is_dir():
        for directory, dirnames, filenames in os.walk(root):
            dirnames.sort()
            for filename in sorted(filenames):
                source = Path(directory) / filename
                if not filename.endswith(TEMPLATE_SUFFIX):
                    raise TemplateError("template file names end in .tmpl", path=source,
                                        hint=f"rename it to {filename}.tmpl")
                relative = PurePosixPath(source.relative_to(root).as_posix())
                files.append((relative.with_name(filename[: -len(TEMPLATE_SUFFIX)]), source))
    fragments: list[tuple[str, Path]] = []
    slots = folder / "slots"
    if slots.is_dir():
        for source in sorted(slots.iterdir()):
            slot = source.name[: -len(TEMPLATE_SUFFIX)]
            if not source.name.endswith(TEMPLATE_SUFFIX) or not TOKEN.fullmatch(f"@{slot}@"):
                raise TemplateError("a slot fragment is named <slot>.tmpl, slot in lowercase "
                                    "letters, digits and underscores", path=source)
            fragments.append((slot, source))
    return Variant(folder.name, folder, tuple(files), tuple(fragments))


def _read(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise TemplateError(f"cannot read the template: {exc}", path=path) from None


def render(text: str, values: Mapping[str, str], *, source: Path,
           slots: Mapping[str, str] | None = None, used: set[str] | None = None) -> str:
    """Substitute the tokens of one template.

    `values` fill `@name@` anywhere; `slots` fill a token standing alone on its line, each
    line of the value indented like the token. An unknown token, or a slot token sharing its
    line, raises TemplateError naming the file and line. Tokens used are added to `used`.
    """
    slots = slots or {}
    out: list[str] = []
    for number, line in enumerate(text.splitlines(keepends=True), 1):
        tokens = TOKEN.findall(line)
        if not tokens:
            out.append(line)
            continue
        if used is not None:
            used.update(tokens)
        slotted = [t for t in tokens if t in slots]
        if slotted:
            if len(tokens) != 1 or line.strip() != f"@{slotted[0]}@":
                raise TemplateError(f"the slot @{slotted[0]}@ must stand alone on its line",
                                    path=source, line=number,
                                    hint="slots are filled with whole lines")
            indent = line[: len(line) - len(line.lstrip())]
            out.extend(indent + part if part.strip() else part
                       for part in slots[slotted[0]].splitlines(keepends=True))
            continue
        try:
            out.append(substitute(line, values, TOKEN))
        except UnknownToken as exc:
            known = ", ".join(f"@{name}@" for name in sorted({*values, *slots}))
            raise TemplateError(f"unknown token @{exc.tokens[0]}@", path=source, line=number,
                                hint=f"known here: {known}") from None
    return "".join(out)


def _render_path(template: PurePosixPath, values: Mapping[str, str], source: Path) -> PurePosixPath:
    parts = []
    for part in template.parts:
        rendered = render(part, values, source=source)
        if not rendered or rendered in (".", "..") or "/" in rendered or "\\" in rendered:
            raise TemplateError(f"the path part {part!r} renders to {rendered!r}", path=source)
        parts.append(rendered)
    return PurePosixPath(*parts)


def check_layout_clash(name: str, build_type: str, variants: Mapping[str, Variant]) -> None:
    """A build type whose templates create a top-level `@package_name@/` folder (a Python
    package) cannot take a name that its templates use for another top-level entry."""
    tops = {template.parts[0] for variant in variants.values() for template, _ in variant.files}
    if "@package_name@" in tops and name in tops:
        raise PackageCreateError(
            f"the package name {name!r} is also the name of the package's {name}/ folder",
            hint=f"{build_type} packages keep their Python code in <name>/; choose "
                 f"another name, e.g. 'my_{name}'")


# ------------------------------------------------------------------------------ composition


def load_build_type(build_dir: Path) -> dict[str, Variant]:
    """Every variant folder of one build type, by name (all are checked, used or not)."""
    variants = {p.name: load_variant(p) for p in sorted(build_dir.iterdir()) if p.is_dir()}
    if BASE_VARIANT not in variants:
        raise TemplateError("no base/ template folder", path=build_dir)
    return variants


def select_variants(build_type: str, names: Collection[str], request: PackageRequest) -> list[str]:
    """The variant folders to compose, in order: base, then one per requested option."""
    if request.dependencies and DEPENDENCY_VARIANT not in names:
        raise PackageCreateError(f"{build_type} packages take no --dependencies",
                                 hint=f"there is no template folder {build_type}/dependency")
    wanted = {"library": request.library_name is not None,
              "node": request.node_name is not None,
              "launch": request.launch}
    chosen = [BASE_VARIANT]
    for option, flag in OPTION_VARIANTS:
        if not wanted[option]:
            continue
        specific = sorted(f"{option}+{dep}" for dep in request.dependencies
                          if f"{option}+{dep}" in names)
        if len(specific) > 1:
            raise PackageCreateError(
                f"{flag} matches several templates: {', '.join(specific)}",
                hint="give only one of " + ", ".join(s.partition('+')[2] for s in specific)
                     + " in --dependencies")
        name = specific[0] if specific else option
        if name not in names:
            offered = [f for o, f in OPTION_VARIANTS if o in names]
            raise PackageCreateError(
                f"{build_type} packages have no {flag} template",
                hint=f"{build_type} offers: {', '.join(offered) or 'no options'}")
        chosen.append(name)
    return chosen


def template_values(request: PackageRequest) -> dict[str, str]:
    """The value tokens; text comes escaped for XML (`_xml`) and as Python literals (`_py`)."""
    values = {
        "package_name": request.name,
        "package_name_upper": request.name.upper(),
        "package_format": str(request.package_format),
        "version": DEFAULT_VERSION,
    }
    for key, text in (("description", request.description),
                      ("maintainer_name", request.maintainer_name),
                      ("maintainer_email", request.maintainer_email),
                      ("license", request.license)):
        values[f"{key}_xml"] = escape(text, {'"': "&quot;"})
        values[f"{key}_py"] = repr(text)
    if request.node_name is not None:
        values["node_name"] = request.node_name
        values["node_class"] = _camel_case(request.node_name)
    if request.library_name is not None:
        values["library_name"] = request.library_name
        values["library_name_upper"] = request.library_name.upper()
    return values


def _camel_case(name: str) -> str:
    return "".join(part[:1].upper() + part[1:] for part in name.split("_") if part)


def render_package(request: PackageRequest, *, root: Path | None = None) -> RenderedPackage:
    """Validate the request and render every file in memory (nothing is written)."""
    root = root or templates_root()
    checked = check_request(request, available_build_types(root))
    request = checked.request
    all_variants = load_build_type(root / "pkg" / request.build_type)
    check_layout_clash(request.name, request.build_type, all_variants)
    chosen = select_variants(request.build_type, all_variants, request)
    variants = [all_variants[name] for name in chosen]
    values = template_values(request)
    every_slot = {slot for variant in all_variants.values() for slot, _ in variant.fragments}
    clash = sorted(every_slot & {*values, "dependency"})
    if clash:
        raise TemplateError(f"@{clash[0]}@ is both a value and a slot",
                            path=root / "pkg" / request.build_type, hint="rename the slot")

    # Round 1: dependency fragments, once per dependency.
    dependency = all_variants.get(DEPENDENCY_VARIANT)
    first: dict[str, str] = {slot: "" for slot, _ in (dependency.fragments if dependency else ())}
    for dep in request.dependencies:
        assert dependency is not None  # select_variants checked
        for slot, source in dependency.fragments:
            first[slot] += _fragment(source, {**values, "dependency": dep}, {})
    # Round 2: the fragments of the chosen folders, which may use round-1 slots and those the
    # folders before them filled (a node links the package's own library: @cmake_own_libraries@)
    slots = {slot: first.get(slot, "") for slot in every_slot}
    filled: set[str] = set()
    for variant in variants:
        for slot, source in variant.fragments:
            text = _fragment(source, values, slots)
            slots[slot] += text
            if text:
                filled.add(slot)

    files: dict[PurePosixPath, tuple[str, str]] = {}
    file_used: set[str] = set()
    for variant in variants:
        for template, source in variant.files:
            path = _render_path(template, values, source)
            if path in files:
                raise PackageCreateError(
                    f"two templates write {path}: {files[path][0]} and {variant.name}",
                    path=source, hint="give --node-name and --library-name names that differ "
                                      "from each other and from the package's own files")
            files[path] = (variant.name, render(_read(source), values, source=source,
                                                slots=slots, used=file_used))
    license_entry = find_license(request.license)
    if license_entry is not None:
        source = root / "licenses" / f"{license_entry.text}{TEMPLATE_SUFFIX}"
        year = str(request.year or datetime.date.today().year)
        text = render(_read(source), {"year": year, "copyright_holder": request.maintainer_name},
                      source=source)
        if PurePosixPath("LICENSE") in files:
            raise TemplateError("a template writes LICENSE, which --license writes",
                                path=root / "pkg" / request.build_type)
        files[PurePosixPath("LICENSE")] = ("license", text)
    # Dependency fragments nobody asks for are fine (no target to link), and so are an option's
    # for a folder not chosen (the library's lines for a node); a slot no template names is not.
    leftover = sorted(filled - file_used - _named_slots(all_variants.values()))
    if leftover:
        raise TemplateError(f"fragments for @{leftover[0]}@ are used by no file",
                            path=root / "pkg" / request.build_type,
                            hint=f"add @{leftover[0]}@ to a file of base/, or remove the fragments")
    return RenderedPackage(
        name=request.name,
        build_type=request.build_type,
        variants=tuple(v.name for v in variants),
        files=tuple(sorted((path, content) for path, (_, content) in files.items())),
        notes=checked.notes,
    )


def _named_slots(variants: Iterable[Variant]) -> set[str]:
    """The tokens the templates of `variants` (files and fragments) name."""
    return {token for variant in variants
            for _, source in (*variant.files, *variant.fragments)
            for token in TOKEN.findall(_read(source))}


def _fragment(source: Path, values: Mapping[str, str], slots: Mapping[str, str]) -> str:
    text = _read(source)
    if text and not text.endswith("\n"):
        raise TemplateError("a slot fragment must end with a line break", path=source)
    return render(text, values, source=source, slots=slots)
