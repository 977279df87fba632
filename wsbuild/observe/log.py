"""What a step's processes wrote down (the interposed library's and the Python hook's lines,
one file per process: observe/interposer.c says what each line means), read into one
`Observation`: the files read and written, the paths looked at and looked for, the directories
listed or searched, the programs run, the environment variables read, and whatever could not
be observed.

Shells and make copy the whole environment into their own variables, so what they read is
what their text names (observe/texts.py). Interpreters that read their environment without
getenv and without a hook of wsbuild's (Perl, Ruby, Node.js, Lua, Tcl, PHP, a Java VM, awk's
ENVIRON) make the step not fully observed, as does a program that ran without the library
(static, setuid, or started with an environment that dropped LD_PRELOAD)."""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from wsbuild.observe.texts import MAKES, SHELLS, make_reads, shell_reads
from wsbuild.patterns import lazy

#: programs that read their environment wholesale, unseen: a step running one is not fully
#: observed
UNSEEN_READERS = lazy(r"^(perl[\d.]*|ruby[\d.]*|node(js)?|lua[\d.]*|luajit|tclsh[\d.]*|"
                            r"wish[\d.]*|php[\d.]*|java|python[\d.]*-dbg)$")
PYTHON = re.compile(r"^(python|pypy)[\d.]*$")
AWK = lazy(r"^(g|m|n)?awk$")
#: variables every program reads without asking getenv: the dynamic loader's
LOADER_READS = ("LD_LIBRARY_PATH",)
#: the arguments a Python interpreter answers before its site module (and so wsbuild's hook)
#: runs, reading nothing but its own executable
_EARLY_EXITS = frozenset({"-V", "--version", "-VV", "-h", "--help"})
#: the largest text of a script or makefile searched for the variables it names
_TEXT_BYTES = 4 * 1024 * 1024


@dataclass(frozen=True, slots=True)
class Observation:
    """What the processes of one or more steps did, absolute paths as they spelled them."""

    reads: frozenset[str] = frozenset()
    writes: frozenset[str] = frozenset()
    #: paths looked at that were there, and looked for that were not
    present: frozenset[str] = frozenset()
    absent: frozenset[str] = frozenset()
    #: directories whose entries were all read
    listings: frozenset[str] = frozenset()
    #: directories searched for some names only: dir -> fnmatch patterns of the names
    searches: dict[str, frozenset[str]] = field(default_factory=dict)
    #: trees walked whole (fts, nftw) and glob(3) patterns expanded
    trees: frozenset[str] = frozenset()
    globs: frozenset[str] = frozenset()
    #: the programs that ran, by the executable's path
    programs: frozenset[str] = frozenset()
    variables: frozenset[str] = frozenset()
    #: some process read every variable's value, or the set of their names
    every_variable: bool = False
    variable_names: bool = False
    #: why not everything the steps did was seen (empty: all was)
    unobserved: tuple[str, ...] = ()

    @property
    def complete(self) -> bool:
        return not self.unobserved


def merged(observations: Iterable[Observation]) -> Observation:
    """One observation of several."""
    parts = list(observations)
    searches: dict[str, set[str]] = {}
    for part in parts:
        for directory, patterns in part.searches.items():
            searches.setdefault(directory, set()).update(patterns)

    def union(name: str) -> frozenset[str]:
        return frozenset().union(*(getattr(part, name) for part in parts))

    return Observation(
        reads=union("reads"), writes=union("writes"), present=union("present"),
        absent=union("absent"), listings=union("listings"),
        searches={d: frozenset(p) for d, p in searches.items()}, trees=union("trees"),
        globs=union("globs"), programs=union("programs"), variables=union("variables"),
        every_variable=any(p.every_variable for p in parts),
        variable_names=any(p.variable_names for p in parts),
        unobserved=tuple(dict.fromkeys(why for p in parts for why in p.unobserved)))


@dataclass(slots=True)
class _Image:
    """One program image of one process: from its I line to the next exec."""

    exe: str = ""
    argv: tuple[str, ...] = ()
    hooked: bool = False
    exec_done: bool = False
    reads: list[str] = field(default_factory=list)
    #: listings before the Python hook ran, and the directories the hook says were searches
    early_listings: list[str] = field(default_factory=list)
    searched: set[str] = field(default_factory=set)


class _Reader:
    def __init__(self, ignored: tuple[str, ...],
                 tool_variables: Mapping[str, frozenset[str]]) -> None:
        self.ignored = ignored
        self.tool_variables = tool_variables
        self.reads: set[str] = set()
        self.writes: set[str] = set()
        self.present: set[str] = set()
        self.absent: set[str] = set()
        self.listings: set[str] = set()
        self.searches: dict[str, set[str]] = {}
        self.trees: set[str] = set()
        self.globs: set[str] = set()
        self.programs: set[str] = set()
        self.variables: set[str] = set(LOADER_READS)
        self.every = False
        self.names = False
        self.unobserved: list[str] = []
        #: pid -> program a posix_spawn started, whose image must show up in its own file
        self.spawned: dict[int, str] = {}
        self.started: set[int] = set()

    def keep(self, path: str) -> bool:
        return not (path + "/").startswith(self.ignored)

    def read_file(self, pid: int, lines: Iterator[str]) -> None:
        image = _Image()
        pending: str | None = None
        for line in lines:
            kind, text = line[:1], _unescape(line[2:])
            if kind == "I":
                if pending is None and image.exe:
                    pass  # a second I without an exec line: an exec the library missed
                pending = None
                image.exec_done = bool(image.exe)
                self._finish(image)
                image = _Image(exe=text)
                self.started.add(pid)
                self.programs.add(text)
            elif kind == "X":
                pending = text
                if self.keep(text):
                    self.present.add(text)
            elif kind == "F":
                pending = None
            elif kind == "A":
                image.argv = tuple(text.split("\x1f"))
            elif kind == "Y":
                child, _, program = text.partition(" ")
                if child.isdigit():
                    self.spawned[int(child)] = program
            else:
                self._event(image, kind, text)
        if pending is not None:
            image.exec_done = True
            self.unobserved.append(f"{pending} ran unobserved (a static or setuid program, "
                                   "or started without the step's LD_PRELOAD)")
        self._finish(image)

    def _event(self, image: _Image, kind: str, text: str) -> None:
        if kind == "E" or kind == "L":
            if kind == "L":
                self.names = True
            elif text not in self.tool_variables.get(os.path.basename(image.exe), ()):
                self.variables.add(text)
            return
        if kind == "H":
            image.hooked = True
            return
        if kind == "C":
            self.reads.update(locale_files(text))
            return
        if kind == "U":
            self.unobserved.append(f"{image.exe or 'a Python process'}: {text}")
            return
        if kind == "K":
            directory, _, name = text.partition("\x1f")
            directory = plain(directory)
            if self.keep(directory) and name:
                self.searches.setdefault(directory, set()).update((name, f"{name}.*"))
            return
        if kind in "QP":
            text = plain(text)
            image.searched.add(text)
            if kind == "P" and self.keep(text):
                self.searches.setdefault(text, set()).add("*.pth")
            return
        text = plain(text)
        if not self.keep(text):
            return
        if kind == "R":
            self.reads.add(text)
            image.reads.append(text)
        elif kind == "W":
            self.writes.add(text)
        elif kind == "S":
            self.present.add(text)
        elif kind == "N":
            self.absent.add(text)
        elif kind == "D":
            if image.hooked:
                self.listings.add(text)
            else:
                image.early_listings.append(text)
        elif kind == "T":
            self.trees.add(text)
        elif kind == "G":
            self.globs.add(text)

    def _finish(self, image: _Image) -> None:
        """What an image read that only its kind says: the listings the Python hook calls
        searches, the variables a shell's or make's text names, a reader no one sees."""
        self.listings.update(d for d in image.early_listings if d not in image.searched)
        if not image.exe:
            return
        name = os.path.basename(image.exe)
        if PYTHON.match(name):
            # `python -V` and `--help` answer before site runs, and read nothing more
            if not image.hooked and not image.exec_done \
                    and not (len(image.argv) == 2 and image.argv[1] in _EARLY_EXITS):
                self.unobserved.append(f"{image.exe} {' '.join(image.argv[1:3])}: started "
                                       "without site or with -E/-I, its environment reads "
                                       "were not observed")
        elif name in SHELLS or name in MAKES:
            texts = [arg for arg in image.argv[1:]] if name in SHELLS else []
            texts += _texts(p for p in image.reads if p != image.exe and ".so" not in p)
            reads = shell_reads(texts) if name in SHELLS else make_reads(texts)
            self.variables.update(reads.names)
            self.every = self.every or reads.every
        elif name in ("env", "printenv"):
            if not _runs_a_command(image.argv):
                operands = [a for a in image.argv[1:] if not a.startswith("-")]
                if name == "printenv" and operands:
                    self.variables.update(operands)
                else:
                    self.every = True
        elif AWK.match(name):
            if any("ENVIRON" in arg for arg in image.argv[1:]):
                self.unobserved.append(f"{image.exe} reads ENVIRON, which is not observed")
        elif UNSEEN_READERS.match(name):
            self.unobserved.append(f"{image.exe} reads its environment unobserved")

    def observation(self) -> Observation:
        for pid, program in sorted(self.spawned.items()):
            if pid not in self.started:
                self.unobserved.append(f"{program} ran unobserved (a static or setuid "
                                       "program, or started without the step's LD_PRELOAD)")
        return Observation(
            reads=frozenset(_sources(self.reads) - self.writes),
            writes=frozenset(self.writes),
            present=frozenset(self.present - self.writes),
            absent=frozenset(self.absent - self.writes),
            listings=frozenset(self.listings), searches={
                d: frozenset(p) for d, p in self.searches.items() if d not in self.listings},
            trees=frozenset(self.trees), globs=frozenset(self.globs),
            programs=frozenset(self.programs), variables=frozenset(self.variables),
            every_variable=self.every, variable_names=self.names,
            unobserved=tuple(dict.fromkeys(self.unobserved)))


def plain(path: str) -> str:
    """`path` without `.`, `..` and doubled slashes, as the kernel resolved it (its directory's
    symlinks followed for a `..`, its last name kept: `src/pkg/../../shared/a.txt` is
    `shared/a.txt`, whatever `pkg` is)."""
    if "//" not in path and "/./" not in path and "/../" not in path \
            and not path.endswith(("/.", "/..")):
        return path
    head, tail = os.path.split(path)
    if tail in (".", ".."):
        return os.path.realpath(path)
    return os.path.join(os.path.realpath(head), tail)


def read_observation(log_dir: Path, *, ignored: Iterable[Path | str] = (),
                     tool_variables: Mapping[str, frozenset[str]] | None = None
                     ) -> Observation:
    """What the processes that wrote into `log_dir` did; paths inside `ignored` (the observer's
    own files, a compiler cache's storage) left out, and the variables `tool_variables` names
    for a program (by its executable's name) not counted when it reads them."""
    reader = _Reader(tuple(sorted({str(p).rstrip("/") + "/" for p in (*ignored, log_dir)})),
                     tool_variables or {})
    try:
        names = sorted(os.listdir(log_dir))
    except OSError:
        return Observation(unobserved=(f"{log_dir}: no observation was written",))
    for name in names:
        stem, dot, suffix = name.partition(".")
        if suffix != "log" or not stem.isdigit():
            continue
        try:
            with open(log_dir / name, encoding="utf-8", errors="surrogateescape") as handle:
                reader.read_file(int(stem), (line.rstrip("\n") for line in handle))
        except OSError as exc:
            reader.unobserved.append(f"{log_dir / name}: {exc.strerror}")
    return reader.observation()


#: where the C library keeps its compiled locales
LOCALES = "/usr/lib/locale"


#: what the C library reads besides a locale's own files when it loads one: the names a locale
#: may be given (locale.alias) and its character set converters' index
LOCALE_SUPPORT = ("/etc/locale.alias", "/usr/share/locale/locale.alias",
                  "/usr/lib/*/gconv/gconv-modules.cache", "/usr/lib/gconv/gconv-modules.cache")


def locale_files(chosen: str) -> set[str]:
    """The files the C library reads for the locale setlocale chose (`C.UTF-8`, or one name
    per category, `LC_CTYPE=…;LC_NUMERIC=…`): its compiled locale's directory, the locale
    archive, and what it reads to find and convert it (`LOCALE_SUPPORT`)."""
    import glob as globbing

    names = {part.partition("=")[2] or part for part in chosen.split(";")}
    found: set[str] = set()
    if names - {"C", "POSIX", ""}:
        found.update(p for pattern in LOCALE_SUPPORT for p in globbing.glob(pattern))
    for name in names - {"C", "POSIX", ""}:
        language, dot, codeset = name.partition(".")
        spellings = {name}
        if dot:
            spellings.add(f"{language}.{codeset.lower().replace('-', '')}")
        for spelling in spellings:
            directory = os.path.join(LOCALES, spelling)
            for root, dirs, files in os.walk(directory):
                found.update(os.path.join(root, f) for f in (*dirs, *files))
        archive = os.path.join(LOCALES, "locale-archive")
        if os.path.exists(archive):
            found.add(archive)
    return found


def _unescape(text: str) -> str:
    if "\\" not in text:
        return text
    return re.sub(r"\\(.)", lambda m: "\n" if m.group(1) == "n" else m.group(1), text)


def _runs_a_command(argv: tuple[str, ...]) -> bool:
    """Whether `env [-i] [NAME=VALUE …] COMMAND` runs a command (then it reads nothing)."""
    args, at = argv[1:], 0
    while at < len(args):
        if args[at] in ("-u", "--unset", "-C", "--chdir"):
            at += 2
        elif args[at].startswith("-") or "=" in args[at]:
            at += 1
        else:
            return True
    return False


def _texts(paths: Iterable[str]) -> Iterator[str]:
    for path in paths:
        try:
            with open(path, "rb") as handle:
                data = handle.read(_TEXT_BYTES)
        except OSError:
            continue
        if b"\0" not in data[:4096]:
            yield data.decode("utf-8", "replace")


_PYC = lazy(r"^(?P<dir>.*)/__pycache__/(?P<name>[^/.]+)\.[^/]+?\.pyc$")


def _sources(reads: Iterable[str]) -> set[str]:
    """Reads of compiled bytecode as reads of its source where the source is there (Python
    reads the .pyc of a module whose source it found unchanged: the source is what decides)."""
    result: set[str] = set()
    for path in reads:
        match = _PYC.match(path) if path.endswith(".pyc") else None
        if match is not None:
            source = f"{match.group('dir')}/{match.group('name')}.py"
            if os.path.exists(source):
                result.add(source)
                continue
        result.add(path)
    return result
