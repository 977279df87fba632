"""Default option values from colcon-defaults files and the workspace's `wsbuild.yaml`.

The format is colcon-defaults': a mapping of verbs to mappings of options to values,

    build:
      symlink-install: true
      cmake-args: [-DCMAKE_BUILD_TYPE=Release]
    pkg.create:
      license: Apache-2.0

verbs nested under another verb joined by a dot, options spelled as on the command line
without the leading `--`. Files, later ones winning option by option:

1. `$COLCON_DEFAULTS_FILE`, else `$COLCON_HOME/defaults.yaml` (COLCON_HOME: `~/.colcon`)
2. `<workspace root>/wsbuild.yaml`

The command line wins over all of them. Unlike colcon, an unknown verb or option and a value
of the wrong type are errors naming the file, the line and what would be valid. The options
are checked against the argument parser itself, so every option any verb has is covered.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from wsbuild.errors import WsbuildError
from wsbuild import inputs
from wsbuild.workspace.root import find_workspace_root

#: the workspace's own defaults file, at its root
WORKSPACE_FILE = "wsbuild.yaml"
DEFAULTS_FILE_VAR = "COLCON_DEFAULTS_FILE"
HOME_VAR = "COLCON_HOME"


class DefaultsError(WsbuildError):
    """A defaults file is unreadable, malformed, or names an option that does not exist."""


@dataclass(frozen=True, slots=True)
class Default:
    """One option value from a defaults file, already checked against the parser."""

    verb: str  # "build", "pkg.create"; "" for the options before the verb
    option: str  # as on the command line without "--": "symlink-install"
    dest: str  # the argparse destination: "symlink_install"
    value: object  # what the option gets (for flags: what the flag stores)
    written: object  # the value as the file has it
    path: Path
    line: int

    @property
    def where(self) -> str:
        return f"{self.path}:{self.line}"

    @property
    def text(self) -> str:
        """`option: value` as in the file (YAML flow style)."""
        return f"{self.option}: {_yaml_text(self.written)}"


def _yaml_text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        return "[" + ", ".join(_yaml_text(v) for v in value) + "]"
    return str(value)


@dataclass(frozen=True, slots=True)
class FileEntry:
    """An option value as read from a file, before it is checked against the parser."""

    verb: str
    option: str
    value: object
    path: Path
    line: int
    verb_line: int


def defaults_files(environ: Mapping[str, str], workspace_root: Path | None) -> list[Path]:
    """The defaults files that exist, lowest priority first.

    `$COLCON_DEFAULTS_FILE` must exist when it is set (colcon ignores a missing one; here a
    typo in the variable would silently change every build)."""
    files: list[Path] = []
    named = environ.get(DEFAULTS_FILE_VAR, "")
    if named:
        path = Path(named).expanduser()
        if not inputs.is_file(path):
            raise DefaultsError(
                f"{DEFAULTS_FILE_VAR} names a file that does not exist", path=path,
                hint=f"create it, or unset {DEFAULTS_FILE_VAR} to use "
                f"${HOME_VAR}/defaults.yaml")
        files.append(path)
    else:
        home = environ.get(HOME_VAR, "")
        user_home = Path(environ["HOME"]) if environ.get("HOME") else Path.home()
        base = Path(home).expanduser() if home else user_home / ".colcon"
        if inputs.is_file(base / "defaults.yaml"):
            files.append(base / "defaults.yaml")
    if workspace_root is not None and inputs.is_file(workspace_root / WORKSPACE_FILE):
        files.append(workspace_root / WORKSPACE_FILE)
    return files


def read_entries(path: Path) -> list[FileEntry]:
    """Every `verb: {option: value}` of one file, with its line; only the shape is checked."""
    import yaml

    try:
        text = inputs.read_text(path)
    except (OSError, UnicodeDecodeError) as exc:
        raise DefaultsError(f"cannot read the defaults file: {exc}", path=path) from None
    loader = yaml.SafeLoader(text)
    try:
        try:
            root = loader.get_single_node()
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark or exc.context_mark
            raise DefaultsError(f"invalid YAML: {exc.problem or exc.context}", path=path,
                                line=mark.line + 1 if mark else None) from None
        if root is None or _is_null(root):
            return []
        if not isinstance(root, yaml.MappingNode):
            raise DefaultsError("expected a mapping of verbs to options", path=path,
                                line=root.start_mark.line + 1,
                                hint="e.g. 'build: {symlink-install: true}'")
        entries: list[FileEntry] = []
        verbs: set[str] = set()
        for verb_node, options_node in root.value:
            verb = _key(verb_node, path, "verb", verbs)
            verb_line = verb_node.start_mark.line + 1
            if _is_null(options_node):
                continue
            if not isinstance(options_node, yaml.MappingNode):
                raise DefaultsError(f"'{verb}' must map option names to values", path=path,
                                    line=options_node.start_mark.line + 1,
                                    hint=f"e.g. '{verb or 'build'}: {{symlink-install: true}}'")
            options: set[str] = set()
            for option_node, value_node in options_node.value:
                option = _key(option_node, path, f"option of '{verb}'", options)
                try:
                    value = loader.construct_object(value_node, deep=True)
                except yaml.MarkedYAMLError as exc:
                    raise DefaultsError(f"invalid value for '{option}': {exc.problem}",
                                        path=path, line=value_node.start_mark.line + 1) from None
                entries.append(FileEntry(verb, option, value, path,
                                      option_node.start_mark.line + 1, verb_line))
        return entries
    finally:
        loader.dispose()


def _is_null(node: object) -> bool:
    import yaml

    return isinstance(node, yaml.ScalarNode) and node.tag == "tag:yaml.org,2002:null"


def _key(node: object, path: Path, what: str, seen: set[str]) -> str:
    import yaml

    assert isinstance(node, yaml.Node)
    line = node.start_mark.line + 1
    if not isinstance(node, yaml.ScalarNode) or node.tag != "tag:yaml.org,2002:str":
        raise DefaultsError(f"a {what} must be a name, not {node.value!r}", path=path, line=line)
    name = str(node.value)
    if name in seen:
        raise DefaultsError(f"duplicate {what} '{name}'", path=path, line=line,
                            hint="YAML keeps only the last one; merge them")
    seen.add(name)
    return name


# --------------------------------------------------------------------------- the parser side


def verb_parsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """"" → the top-level parser, "build" → its parser, "pkg.create" → ..., for every verb."""
    result = {"": parser}
    stack = [("", parser)]
    while stack:
        prefix, current = stack.pop()
        for action in current._actions:  # argparse has no public walk
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    key = f"{prefix}.{name}" if prefix else name
                    result[key] = sub
                    stack.append((key, sub))
    return dict(sorted(result.items()))


def settable_options(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    """Option name without '--' → its action, for every option a defaults file may set."""
    result: dict[str, argparse.Action] = {}
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._VersionAction,
                               argparse._SubParsersAction)):
            continue
        if action.help == argparse.SUPPRESS and isinstance(action, argparse._StoreFalseAction):
            continue  # an on/off option's --no- form (verbs/arguments.py): set the option false
        for option in action.option_strings:  # each name of it (--require-linters,
            if option.startswith("--"):        # --strict-linters)
                result[option[2:]] = action
    return dict(sorted(result.items()))


def _is_flag(action: argparse.Action) -> bool:
    return isinstance(action, (argparse._StoreTrueAction, argparse._StoreFalseAction,
                               argparse._StoreConstAction))


def _is_list(action: argparse.Action) -> bool:
    return isinstance(action, argparse._AppendAction) or action.nargs in ("*", "+") or (
        isinstance(action.nargs, int))


def _item_type(action: argparse.Action) -> type:
    if isinstance(action, argparse._CountAction):
        return int
    return action.type if action.type in (int, float) else str  # type: ignore[return-value]


def _describe(action: argparse.Action) -> str:
    if _is_flag(action):
        return "true or false"
    item = {int: "integer", float: "number", str: "string"}[_item_type(action)]
    if _is_list(action):
        return f"a list of {item}s, e.g. [a, b]" if item == "string" else f"a list of {item}s"
    return f"an {item}" if item == "integer" else f"a {item}"


class _ReplacedByCommandLine(list):  # type: ignore[type-arg]
    """A list default of an `append` option: argparse copies the default before appending the
    first command-line value, and this copy starts empty, so the command line replaces the
    defaults file's list instead of extending it (as for every other option)."""

    def __copy__(self) -> list[object]:
        return []


def _checked(entry: FileEntry, action: argparse.Action) -> Default:
    value = entry.value
    expected = _describe(action)

    def fail(problem: str) -> DefaultsError:
        return DefaultsError(f"'{entry.verb}: {entry.option}': {problem}", path=entry.path,
                             line=entry.line)

    if _is_flag(action):
        if not isinstance(value, bool):
            raise fail(f"expected {expected}, got {value!r}")
        return Default(entry.verb, entry.option, action.dest,
                       action.const if value else action.default, value, entry.path, entry.line)
    items = value if _is_list(action) else [value]
    if _is_list(action) and not isinstance(value, list):
        raise fail(f"expected {expected}, got {value!r}")
    if action.nargs == "+" and not items:
        raise fail("expected at least one value")
    item_type = _item_type(action)
    converted: list[object] = []
    for item in items:
        if isinstance(item, bool) or isinstance(item, (list, dict)) or item is None:
            raise fail(f"expected {expected}, got {value!r}")
        if item_type is str:
            # a number where a string is expected is what the user would have typed
            if not isinstance(item, (str, int, float)):
                raise fail(f"expected {expected}, got {value!r}")
            item = str(item)
        elif item_type is int and not isinstance(item, int):
            raise fail(f"expected {expected}, got {value!r}")
        elif item_type is float and not isinstance(item, (int, float)):
            raise fail(f"expected {expected}, got {value!r}")
        if action.choices is not None and item not in action.choices:
            choices = ", ".join(str(c) for c in action.choices)
            raise fail(f"{item!r} is not one of the choices: {choices}")
        converted.append(item)
    stored: object
    if isinstance(action, argparse._AppendAction):
        stored = _ReplacedByCommandLine(converted)
    elif _is_list(action):
        stored = converted
    else:
        stored = converted[0]
    return Default(entry.verb, entry.option, action.dest, stored, value, entry.path, entry.line)


def check_value(entry: FileEntry, action: argparse.Action) -> object:
    """The value `entry` gives `action`, checked and converted (a mixin's, a defaults file's)."""
    return _checked(entry, action).value


def check_entries(entries: Iterable[FileEntry], parser: argparse.ArgumentParser) -> list[Default]:
    """Check each entry (of every verb, not only the one being run) against the parser of
    its verb; a later entry for the same option replaces an earlier one."""
    parsers = verb_parsers(parser)
    valid_verbs = [v for v in parsers if v]
    result: dict[tuple[str, str], Default] = {}
    for entry in entries:
        parser = parsers.get(entry.verb)
        if parser is None:
            raise DefaultsError(
                f"unknown verb '{entry.verb}'", path=entry.path, line=entry.verb_line,
                hint=_suggestion(entry.verb, valid_verbs, "verbs"))
        options = settable_options(parser)
        action = options.get(entry.option)
        if action is None:
            if entry.option.startswith("-"):
                bare = entry.option.lstrip("-")
                hint = f"write option names without the leading dashes: '{bare}'"
            elif not options:
                hint = f"'{entry.verb or 'wsbuild'}' has no options to set"
            else:
                hint = _suggestion(entry.option, list(options), f"options of '{entry.verb}'")
            raise DefaultsError(f"'{entry.verb}' has no option '{entry.option}'",
                                path=entry.path, line=entry.line, hint=hint)
        result[(entry.verb, entry.option)] = _checked(entry, action)
    return list(result.values())


def _suggestion(name: str, valid: Sequence[str], what: str) -> str:
    """The name meant when one is close (enough: the list of ~70 options would bury it),
    else the valid names."""
    import difflib  # lazy: off every command line that names no unknown key

    close = difflib.get_close_matches(name.replace("_", "-"), valid, n=1)
    return f"did you mean '{close[0]}'?" if close else f"{what}: {', '.join(valid)}"


# ---------------------------------------------------------------------- applying the values


def chosen_verb(parser: argparse.ArgumentParser, argv: Sequence[str]) -> str:
    """The verb key ("build", "pkg.create") the command line `argv` runs, "" if none."""
    parsers = verb_parsers(parser)
    #: the options before the verb that take a value (`wsbuild --log-base DIR build`)
    with_value = {o for a in parser._actions if a.nargs != 0 for o in a.option_strings}
    key = ""
    skip = False
    for item in argv:
        if skip:
            skip = False
            continue
        if item.startswith("-"):
            if key:
                break
            skip = item in with_value
            continue
        candidate = f"{key}.{item}" if key else item
        if candidate not in parsers:
            break
        key = candidate
    return key


def apply_defaults(parser: argparse.ArgumentParser, verb: str,
                   defaults: Sequence[Default]) -> list[Default]:
    """Make the defaults of `verb` (and of the verbs it is nested in) the parser's defaults,
    and list them in the verb's --help. Returns the defaults that apply."""
    parsers = verb_parsers(parser)
    chain = [""]
    parts = verb.split(".") if verb else []
    chain += [".".join(parts[: i + 1]) for i in range(len(parts))]
    applying = [d for d in defaults if d.verb in chain]
    for key in chain:
        values = {d.dest: d.value for d in applying if d.verb == key}
        if values:
            parsers[key].set_defaults(**values)
    if verb in parsers:
        _describe_in_help(parsers[verb], applying)
    return applying


def _describe_in_help(parser: argparse.ArgumentParser, applying: Sequence[Default]) -> None:
    if not applying:
        return
    width = min(40, max(len(d.text) for d in applying))
    lines = ["defaults in effect (from defaults files; the command line overrides them, an "
             "on/off option with its --no- form, e.g. --no-symlink-install):"]
    lines += [f"  {d.text.ljust(width)}  {d.where}" for d in applying]
    extra = "\n".join(lines)
    parser.epilog = f"{parser.epilog.rstrip()}\n\n{extra}" if parser.epilog else extra


def workspace_option(argv: Sequence[str]) -> str | None:
    """The value of -C/--workspace in `argv`, if given (before the full parse, which needs the
    defaults, which need the workspace root)."""
    for index, item in enumerate(argv):
        if item == "--":
            break
        name, equals, value = item.partition("=")
        # argparse also takes unambiguous abbreviations: --work
        is_long = len(name) > 3 and "--workspace".startswith(name)
        if (item == "-C" or is_long) and not equals and index + 1 < len(argv):
            return argv[index + 1]
        if is_long and equals:
            return value
        if item.startswith("-C") and len(item) > 2 and not item.startswith("--"):
            return item[2:]
    return None


def _root_for(workspace: str | None, cwd: Path) -> Path:
    return (cwd / workspace).absolute() if workspace else find_workspace_root(cwd)


def _needs_more(parser: argparse.ArgumentParser, argv: Sequence[str],
                entries: Sequence[FileEntry]) -> bool:
    """Whether `parser` lacks what `argv` or the files' `entries` ask for: --help (which
    lists every option), an option it does not know."""
    if any(item in _HELP for item in argv):
        return True
    try:
        check_entries(entries, parser)
    except DefaultsError:
        return True
    import contextlib
    import io

    # argparse reports a bad value (and --version) by exiting: the real parse's to do
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        try:
            _args, extra = parser.parse_known_args(argv)
        except SystemExit:
            return False
    return bool(extra)


def _parse(parser: argparse.ArgumentParser, argv: Sequence[str]) -> argparse.Namespace:
    """parse_args, but an unknown argument is reported with the usage of the verb it follows
    (argparse names the top-level usage)."""
    args, extra = parser.parse_known_args(argv)
    if extra:
        verb = verb_parsers(parser).get(chosen_verb(parser, argv), parser)
        verb.error(f"unrecognized arguments: {' '.join(extra)}")
    return args


_HELP = ("-h", "--help", "--help-all")


def parse_with_defaults(
    argv: Sequence[str],
    environ: Mapping[str, str],
    cwd: Path,
    make_parser: Callable[[set[str]], argparse.ArgumentParser],
    finish: Callable[[argparse.ArgumentParser, str, argparse.Namespace], None] | None = None,
    *,
    make_full_parser: Callable[[set[str]], argparse.ArgumentParser] | None = None,
) -> argparse.Namespace:
    """Parse `argv` with the defaults files' values as defaults: the command line wins.

    `make_parser(verbs)` builds the argument tree; `verbs` are those the files set options
    for (so a lazily built part of the tree can be included when a file needs it).
    `make_full_parser(verbs)`, when given, builds it with the options that cost to find (the
    third-party build types'): used for --help, and when the command line or a file holds an
    option the first tree does not know. The workspace root (for `wsbuild.yaml`) comes from
    -C/--workspace or the current directory. `finish(parser, verb, args)` completes the
    arguments of the verb that runs (mixins).
    """
    root = _root_for(workspace_option(argv), cwd)
    for _attempt in range(2):
        files = defaults_files(environ, root)
        entries = [entry for path in files for entry in read_entries(path)]
        verbs = {entry.verb for entry in entries}
        parser = make_parser(verbs)
        if make_full_parser is not None and _needs_more(parser, argv, entries):
            parser = make_full_parser(verbs)
        defaults = check_entries(entries, parser)
        apply_defaults(parser, chosen_verb(parser, argv), defaults)
        args = _parse(parser, argv)
        # -C spelled in a way the quick look missed (e.g. abbreviated): read the right file
        actual = _root_for(getattr(args, "workspace_dir", None), cwd)
        if actual == root:
            break
        root = actual
    if finish is not None:
        verb = chosen_verb(parser, argv)
        finish(verb_parsers(parser).get(verb, parser), verb, args)
    return args
