"""colcon-mixin's named option sets: the *.mixin files (in colcon-mixin's places and format),
`--mixin NAME…` applied to a verb's arguments as colcon-mixin does, and `wsbuild mixin
add|remove|update|list|show` over colcon-mixin's repository index (http(s):// or file://)."""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from wsbuild.errors import WsbuildError
from wsbuild.files import atomic_write
from wsbuild import inputs
from wsbuild.verbs.arguments import secondary

MIXIN_DOC = """Manage colcon-mixin's named option sets (`--mixin NAME` of build, test, …).

The files and the repository list are colcon-mixin's own ($COLCON_HOME, default ~/.colcon:
mixin_repositories.yaml and mixin/<repository>/*.mixin; also $COLCON_MIXIN_PATH), so a
machine set up for colcon works as is, and the other way round.

examples:
  wsbuild mixin add default \\
    https://raw.githubusercontent.com/colcon/colcon-mixin-repository/master/index.yaml
  wsbuild mixin update default
  wsbuild mixin show build
  wsbuild build --mixin release ccache
"""

#: colcon-mixin's own variables and file names
HOME_VAR = "COLCON_HOME"
PATH_VAR = "COLCON_MIXIN_PATH"
REPOSITORIES_FILE = "mixin_repositories.yaml"
MIXIN_DIR = "mixin"
#: the verbs colcon-mixin never gives a --mixin (colcon-mixin's blocklist)
NOT_MIXED = ("mixin", "metadata")


class MixinError(WsbuildError):
    """A mixin file, index or repository is unreadable or malformed, or a mixin is unknown."""


@dataclass(frozen=True, slots=True)
class Mixin:
    """One named option set of one verb, as its file has it."""

    verb: str  # "build", "test", "pkg.create"
    name: str
    options: Mapping[str, object]  # option name without "--" → value
    lines: Mapping[str, int]  # option name → its line in `path`
    path: Path
    line: int


def config_home(environ: Mapping[str, str]) -> Path:
    """$COLCON_HOME, else ~/.colcon (where colcon-mixin keeps its files)."""
    if environ.get(HOME_VAR):
        return Path(environ[HOME_VAR]).expanduser()
    home = Path(environ["HOME"]) if environ.get("HOME") else Path.home()
    return home / ".colcon"


def mixin_files(directory: Path) -> list[Path]:
    """Every *.mixin file under `directory`, directories starting with a dot skipped, sorted;
    each listing declared (wsbuild/inputs.py: a mixin file added, changed or removed after a
    recorded no-op runs the full build)."""
    return [Path(path) for path in inputs.walk_files(directory) if path.endswith(".mixin")]


def read_mixin_file(path: Path) -> list[Mixin]:
    """The mixins of one file: `{verb: {name: {option: value}}}` (JSON or YAML)."""
    try:
        text = inputs.read_text(path)
    except (OSError, UnicodeDecodeError) as exc:
        raise MixinError(f"cannot read the mixin file: {exc}", path=path) from None
    return parse_mixins(text, path)


def parse_mixins(text: str, path: Path) -> list[Mixin]:
    """The mixins of the text of mixin file `path` (named in errors and in each Mixin)."""
    import yaml

    loader = yaml.SafeLoader(text)
    try:
        root = loader.get_single_node()
        if root is None:
            return []
        result: list[Mixin] = []
        for verb_node, mixins_node in _mapping(root, path, "verbs to mixins"):
            for name_node, options_node in _mapping(mixins_node, path, "mixin names to options"):
                pairs = _mapping(options_node, path, "option names to values")
                options = {str(k.value): loader.construct_object(v, deep=True) for k, v in pairs}
                lines = {str(k.value): k.start_mark.line + 1 for k, _ in pairs}
                result.append(Mixin(str(verb_node.value), str(name_node.value), options, lines,
                                    path, name_node.start_mark.line + 1))
        return result
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        raise MixinError(f"invalid YAML: {exc.problem or exc.context}", path=path,
                         line=mark.line + 1 if mark else None) from None
    finally:
        loader.dispose()


def _mapping(node: object, path: Path, what: str) -> list[tuple[object, object]]:
    import yaml

    if not isinstance(node, yaml.MappingNode):
        line = node.start_mark.line + 1 if isinstance(node, yaml.Node) else None
        raise MixinError(f"expected a mapping of {what}", path=path, line=line,
                         hint='e.g. {"build": {"release": {"cmake-args": '
                              '["-DCMAKE_BUILD_TYPE=Release"]}}}')
    return list(node.value)


def mixin_locations(environ: Mapping[str, str]) -> list[Path]:
    """Where mixin files are looked for: $COLCON_HOME/mixin, then $COLCON_MIXIN_PATH."""
    extra = [Path(p) for p in environ.get(PATH_VAR, "").split(os.pathsep) if p]
    return [config_home(environ) / MIXIN_DIR, *extra]


def known_mixins(environ: Mapping[str, str], extra_files: Sequence[str] = (),
                 cwd: Path | None = None) -> dict[str, dict[str, Mixin]]:
    """verb → name → mixin, from every mixin file (a later file's mixin replaces an earlier);
    `extra_files` (--mixin-files) are relative to `cwd`."""
    files = [f for location in mixin_locations(environ) for f in mixin_files(location)]
    for name in extra_files:
        path = (cwd or Path.cwd()) / name
        if not inputs.is_file(path):
            raise MixinError("--mixin-files: no such file", path=path)
        files.append(path)
    result: dict[str, dict[str, Mixin]] = {}
    for path in files:
        for mixin in read_mixin_file(path):
            result.setdefault(mixin.verb, {})[mixin.name] = mixin
    return result


def application_order(mixins: Mapping[str, Mixin], requested: str) -> list[str]:
    """`requested` after the mixins it names under its `mixin` key, depth first (colcon-mixin's
    order: the referring mixin is applied last, so it wins)."""
    order: list[str] = []

    def visit(name: str, path: tuple[str, ...]) -> None:
        if name in path:
            raise MixinError(f"mixins refer to each other in a circle: {' -> '.join((*path, name))}",
                             path=mixins[name].path, line=mixins[name].line)
        refs = mixins[name].options.get("mixin", [])
        if not isinstance(refs, list) or not all(isinstance(r, str) for r in refs):
            raise MixinError(f"mixin '{name}': 'mixin' must be a list of mixin names",
                             path=mixins[name].path, line=mixins[name].lines.get("mixin"))
        for ref in refs:
            if ref not in mixins:
                raise MixinError(f"mixin '{name}' refers to unknown mixin '{ref}'",
                                 path=mixins[name].path, line=mixins[name].lines.get("mixin"))
            visit(ref, (*path, name))
        order.append(name)

    visit(requested, ())
    return order


def add_mixin_arguments(parser: argparse._ActionsContainer) -> None:
    """--mixin and --mixin-files (apply_mixins reads them)."""
    secondary(parser.add_argument(
        "--mixin", nargs="*", metavar="NAME",
        help="colcon-mixin's named option sets, e.g. release ccache (wsbuild mixin show)"))
    secondary(parser.add_argument("--mixin-files", nargs="*", metavar="FILE",
                                  help="more *.mixin files to take mixins from"))


def apply_mixins(parser: argparse.ArgumentParser, verb: str, args: argparse.Namespace,
                 environ: Mapping[str, str], cwd: Path | None = None) -> None:
    """Merge the mixins `args.mixin` names into `args` as colcon-mixin does: a list option
    gets the mixin's values before the command line's, any other option takes the mixin's value
    only where the command line left the default."""
    requested = list(getattr(args, "mixin", None) or ())
    if not requested:
        return
    mixins = known_mixins(environ, getattr(args, "mixin_files", None) or (), cwd).get(verb, {})
    for name in requested:
        if name not in mixins:
            known = ", ".join(sorted(mixins)) or "none"
            raise MixinError(
                f"--mixin: no mixin '{name}' for '{verb.replace('.', ' ')}' (known: {known})",
                hint="'wsbuild mixin update' fetches the repositories' mixins; "
                     "'wsbuild mixin show' lists them")
    order = [m for name in requested for m in application_order(mixins, name)]
    for name in reversed(order):
        _apply(parser, mixins[name], args)


def _apply(parser: argparse.ArgumentParser, mixin: Mixin, args: argparse.Namespace) -> None:
    from wsbuild.verbs.defaults import (
        FileEntry, check_value, settable_options)  # lazy: off Tab completion

    options = settable_options(parser)
    for key, value in mixin.options.items():
        if key == "mixin":
            continue
        line = mixin.lines.get(key, mixin.line)
        action = options.get(key)
        if action is None:
            raise MixinError(f"mixin '{mixin.name}': 'wsbuild {mixin.verb}' has no option "
                             f"'--{key}'", path=mixin.path, line=line)
        try:
            converted = check_value(FileEntry(mixin.verb, key, value, mixin.path, line,
                                              mixin.line), action)
        except WsbuildError as exc:  # the defaults files' checks, said of the mixin
            raise MixinError(f"mixin '{mixin.name}': {exc.message}", path=exc.path,
                             line=exc.line, hint=exc.hint) from None
        current = getattr(args, action.dest, None)
        if current is None or current == parser.get_default(action.dest):
            setattr(args, action.dest, list(converted) if isinstance(converted, list)
                    else converted)
        elif isinstance(current, list) and isinstance(converted, list):
            setattr(args, action.dest, [*converted, *current])


# ------------------------------------------------------------------ the repositories (verb)


def repositories_file(environ: Mapping[str, str]) -> Path:
    return config_home(environ) / REPOSITORIES_FILE


def read_repositories(environ: Mapping[str, str]) -> dict[str, str]:
    """name → index URL, from colcon-mixin's mixin_repositories.yaml."""
    import yaml

    path = repositories_file(environ)
    if not inputs.is_file(path):
        return {}
    try:
        data = yaml.safe_load(inputs.read_text(path))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise MixinError(f"cannot read the mixin repositories: {exc}", path=path) from None
    if data is None:
        return {}
    if not isinstance(data, dict) or not all(isinstance(v, str) for v in data.values()):
        raise MixinError("expected a mapping of repository names to index URLs", path=path)
    return {str(k): v for k, v in data.items()}


def write_repositories(environ: Mapping[str, str], repositories: Mapping[str, str]) -> None:
    import yaml

    path = repositories_file(environ)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(dict(sorted(repositories.items())),
                                   default_flow_style=False), encoding="utf-8")


def fetch(url: str, timeout: float = 10.0) -> str:
    """The text at an http(s):// or file:// URL (a plain path is a file)."""
    from urllib.error import URLError
    from urllib.request import urlopen

    if "://" not in url:
        url = Path(url).absolute().as_uri()
    if not url.startswith(("http://", "https://", "file://")):
        raise MixinError(f"cannot fetch '{url}': only http://, https:// and file:// URLs")
    try:
        with urlopen(url, timeout=timeout) as response:  # noqa: S310 (schemes checked above)
            return response.read().decode("utf-8")
    except (URLError, OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "reason", exc)
        raise MixinError(f"cannot fetch '{url}': {reason}") from None


def as_url(location: str) -> str:
    """An index location as a URL (a plain path is a file:// URL)."""
    return location if "://" in location else Path(location).absolute().as_uri()


def index_entries(index_url: str, text: str) -> dict[str, str]:
    """The mixin files of a repository index (`mixin: [file, …]`): file name → URL, each
    entry resolved against the index's own URL. Every entry must name a `.mixin` file, and an
    index served over http(s) only files of its own origin (no local path, no file:// URL,
    no other server)."""
    from urllib.parse import unquote, urljoin, urlsplit

    import yaml

    index_url = as_url(index_url)
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise MixinError(f"the index at '{index_url}' is not YAML: {exc}") from None
    if not isinstance(data, dict) or not isinstance(data.get("mixin"), list):
        raise MixinError(f"the index at '{index_url}' has no 'mixin' list",
                         hint="an index is 'mixin: [build-type.mixin, ...]'")
    origin = _origin(index_url)
    files: dict[str, str] = {}
    for entry in data["mixin"]:
        url = urljoin(index_url, str(entry).strip())
        basename = unquote(urlsplit(url).path.rpartition("/")[2])
        if not isinstance(entry, str) or not _is_mixin_file_name(basename):
            raise MixinError(f"the index at '{index_url}' names '{entry}', which is not a "
                             "mixin file", hint="each entry is a file name ending in .mixin, "
                                                "e.g. build-type.mixin")
        if origin is not None and _origin(url) != origin:
            raise MixinError(f"the index at '{index_url}' names '{entry}', which is not on its "
                             f"own server ({origin[0]}://{origin[1]}:{origin[2]})",
                             hint="an index served over http(s) may name only files of its "
                                  "own origin")
        if basename in files:
            raise MixinError(f"the index at '{index_url}' names two mixin files '{basename}'")
        files[basename] = url
    return files


def _is_mixin_file_name(name: str) -> bool:
    return (name.endswith(".mixin") and not name.startswith(".")
            and not any(c in name for c in "/\\\0"))


def _origin(url: str) -> tuple[str, str, int] | None:
    """(scheme, host, port) of an http(s) URL; None for a local (file://) one."""
    from urllib.parse import urlsplit

    parts = urlsplit(url)
    scheme = parts.scheme.lower()
    if scheme not in ("http", "https"):
        return None
    try:
        port = parts.port or (443 if scheme == "https" else 80)
    except ValueError:  # a port that is not a number: no origin matches it
        port = -1
    return scheme, (parts.hostname or "").lower(), port


def update_repository(environ: Mapping[str, str], name: str, index_url: str,
                      say: Callable[[str], None]) -> list[MixinError]:
    """Fetch the index and its mixin files into $COLCON_HOME/mixin/<name>/ (stale ones go).
    A file that is not a valid mixin file is refused, its last good copy kept: the refusals
    are returned. A malformed index changes nothing (MixinError)."""
    files = index_entries(index_url, fetch(index_url))
    target = config_home(environ) / MIXIN_DIR / name
    contents = {basename: fetch(url) for basename, url in files.items()}
    target.mkdir(parents=True, exist_ok=True)
    refused: list[MixinError] = []
    for basename, text in contents.items():
        path = target / basename
        try:
            parse_mixins(text, path)
        except MixinError as exc:
            where = f"line {exc.line}: " if exc.line else ""
            kept = "kept the last good copy" if path.is_file() else "not installed"
            refused.append(MixinError(f"refused {basename} from '{files[basename]}': "
                                      f"{where}{exc.message} ({kept})"))
            say(f"  ! {basename}")
            continue
        old = path.read_text(encoding="utf-8") if path.is_file() else None
        if old != text:
            atomic_write(path, text)
        say(f"  {'+' if old is None else '.' if old == text else '*'} {basename}")
    for stale in sorted(target.glob("*.mixin")):
        if stale.name not in contents:
            stale.unlink()
            say(f"  - {stale.name}")
    return refused


# ------------------------------------------------------------------------- the verb's actions


def add_arguments(actions: argparse._SubParsersAction,
                  make: Callable[..., argparse.ArgumentParser]) -> None:
    """The actions of `wsbuild mixin`; `make(name, help)` adds one (cli.py's formatter)."""
    add = make("add", "add a repository of mixins by its index URL")
    add.add_argument("name", help="a name for the repository")
    add.add_argument("url", help="its index.yaml: http(s)://… or file://…")
    add.set_defaults(func="wsbuild.verbs.mixin:run_add")
    remove = make("remove", "forget a repository and its mixin files")
    remove.add_argument("name")
    remove.set_defaults(func="wsbuild.verbs.mixin:run_remove")
    update = make("update", "fetch the mixin files of every repository (or one)")
    update.add_argument("name", nargs="?")
    update.set_defaults(func="wsbuild.verbs.mixin:run_update")
    listing = make("list", "the repositories and their mixin files")
    listing.add_argument("name", nargs="?")
    listing.set_defaults(func="wsbuild.verbs.mixin:run_list")
    show = make("show", "the mixins of every verb (or one) with their options")
    show.add_argument("verb", nargs="?", help="e.g. build")
    show.add_argument("mixin_name", nargs="?", metavar="MIXIN")
    show.set_defaults(func="wsbuild.verbs.mixin:run_show")


def run_add(args: argparse.Namespace) -> int:
    """Register a repository index under a name (nothing is fetched: `mixin update`)."""
    repositories = read_repositories(os.environ)
    if args.name in repositories:
        raise MixinError(f"a mixin repository '{args.name}' exists already "
                         f"({repositories[args.name]})", hint="wsbuild mixin remove it first")
    repositories[args.name] = args.url
    write_repositories(os.environ, repositories)
    print(f"added {args.name}: {args.url} (fetch its mixins: wsbuild mixin update {args.name})")
    return 0


def run_remove(args: argparse.Namespace) -> int:
    import shutil

    repositories = read_repositories(os.environ)
    if args.name not in repositories:
        raise MixinError(f"no mixin repository '{args.name}'",
                         hint=f"known: {', '.join(sorted(repositories)) or 'none'}")
    del repositories[args.name]
    write_repositories(os.environ, repositories)
    shutil.rmtree(config_home(os.environ) / MIXIN_DIR / args.name, ignore_errors=True)
    print(f"removed {args.name}")
    return 0


def run_update(args: argparse.Namespace) -> int:
    repositories = read_repositories(os.environ)
    if args.name is not None and args.name not in repositories:
        raise MixinError(f"no mixin repository '{args.name}'",
                         hint=f"known: {', '.join(sorted(repositories)) or 'none'}")
    failed = 0
    for name, url in sorted(repositories.items()):
        if args.name not in (None, name):
            continue
        print(f"fetching {name}: {url}")
        try:
            refused = update_repository(os.environ, name, url, print)
        except MixinError as exc:
            refused = [exc]
        for exc in refused:
            print(f"wsbuild: error: {exc}", flush=True)
        failed += bool(refused)
    return 1 if failed else 0


def run_list(args: argparse.Namespace) -> int:
    repositories = read_repositories(os.environ)
    for name, url in sorted(repositories.items()):
        if args.name not in (None, name):
            continue
        print(f"{name}: {url}")
        for path in mixin_files(config_home(os.environ) / MIXIN_DIR / name):
            print(f"- {path}")
    return 0


def run_show(args: argparse.Namespace) -> int:
    mixins = known_mixins(os.environ)
    for verb in sorted(mixins):
        if args.verb not in (None, verb):
            continue
        print(f"{verb}:")
        for name, mixin in sorted(mixins[verb].items()):
            if args.mixin_name not in (None, name):
                continue
            print(f"- {name}:")
            for key, value in mixin.options.items():
                print(f"    {key}: {value}")
    return 0
