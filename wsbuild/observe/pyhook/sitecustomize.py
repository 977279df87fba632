"""wsbuild's observer in a Python process of a build or test step. It is on the step's
PYTHONPATH, alone in its directory, and hands over to the `sitecustomize` that would have run
without it. It writes into the step's observation log (WSOBSERVE_DIR/<pid>.log, beside what
the interposed C library writes there):

- `H <interpreter>`: the hook ran (a Python process without it, started with -E, -I or -S, is
  not fully observed);
- `E <name>`: a variable read through `os.environ` (which getenv never sees: Python copies the
  environment into a dict at start). A copy of the whole environment (`dict(os.environ)`,
  `os.environ.copy()`, the items handed to a child process) reads no variable: the child
  reads what it reads, and is observed itself. Any other iteration reads the set of names
  (`L`) and each value it looks at;
- `Q <dir>`, `K <dir>\\x1f<name>`, `P <dir>`: the import system listed `dir` only to look
  module names up in it (`K`: each name looked up), and site.py listed a site directory only
  for its `.pth` files: such a listing is a search for those names, not a read of every entry
  (the C library leaves out the listings made while `WSOBSERVE_QUIET` is set).

This file must not import wsbuild and must run on every Python >= 3.8."""

import os
import sys


def _observe():
    """Observe this process from now on, into WSOBSERVE_DIR (a process observed already, a
    warm helper of wsbuild's, writes into the new directory from now on)."""
    directory = os.environ.get("WSOBSERVE_DIR", "")
    if not directory.startswith("/"):
        return
    state = getattr(type(os.environ), "_wsobserve_state", None)
    if state is not None:
        state.update(dir=directory, pid=-1, fd=-1)
        state["write"]("H", sys.executable)
        return
    seen = set()
    state = {"dir": directory, "pid": -1, "fd": -1}

    def write(kind, name):
        if not state["dir"]:
            return
        pid = os.getpid()
        if state["pid"] != pid:  # a fork, a new directory: a file of its own
            seen.clear()
            state["pid"], state["fd"] = pid, -1
        if (kind, name) in seen:
            return
        seen.add((kind, name))
        try:
            if state["fd"] < 0:
                state["fd"] = os.open(f"{state['dir']}/{pid}.log",
                                      os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC,
                                      0o600)
            text = name.replace("\\", "\\\\").replace("\n", "\\n")
            os.write(state["fd"], f"{kind} {text}\n".encode("utf-8", "surrogateescape"))
        except OSError:
            pass

    state["write"] = write
    _observe_environ(write, state)
    _observe_imports(write)
    write("H", sys.executable)


def _stop():
    """Observe nothing more (a warm helper between requests)."""
    state = getattr(type(os.environ), "_wsobserve_state", None)
    if state is not None:
        state.update(dir=None, pid=-1, fd=-1)


def _observe_environ(write, state):
    base = type(os.environ)

    class ObservedEnviron(base):
        _wsobserve_state = state
        # an iteration in progress: the names in order, how far a copy has read them, and the
        # names read so far (written only when it turns out not to be a copy)
        _wsobserve_names = None
        _wsobserve_at = 0
        _wsobserve_held = ()

        def _wsobserve_settle(self, copy_done):
            if self._wsobserve_names is None:
                return
            held = self._wsobserve_held
            self._wsobserve_names, self._wsobserve_held = None, ()
            if not copy_done:
                write("L", "")
                for name in held:
                    write("E", name)

        def __iter__(self):
            self._wsobserve_settle(False)
            names = list(base.__iter__(self))
            self._wsobserve_names, self._wsobserve_at, self._wsobserve_held = names, 0, []
            return iter(names)

        def keys(self):
            self.__iter__()
            return base.keys(self)

        def __getitem__(self, name):
            names = self._wsobserve_names
            if names is not None:
                at = self._wsobserve_at
                if at < len(names) and names[at] == name:
                    self._wsobserve_at = at + 1
                    self._wsobserve_held.append(name)
                    if at + 1 == len(names):
                        self._wsobserve_settle(True)
                    return base.__getitem__(self, name)
                self._wsobserve_settle(False)
            if isinstance(name, str):
                write("E", name)
            return base.__getitem__(self, name)

        def __contains__(self, name):
            if isinstance(name, str):
                self._wsobserve_settle(False)
                write("E", name)
            return base.__contains__(self, name)

        def copy(self):
            return {name: base.__getitem__(self, name) for name in base.__iter__(self)}

    try:
        os.environ.__class__ = ObservedEnviron
    except TypeError:
        write("U", "os.environ could not be observed")
        return
    import atexit

    atexit.register(lambda: os.environ._wsobserve_settle(False))


def _observe_imports(write):
    """The import system's listings as searches: those made before this hook ran (the
    finders already filled, and each module imported so far looked up in the directories
    before the one it came from), and every one after."""
    try:
        from importlib.machinery import FileFinder
    except ImportError:
        return
    import site

    try:
        site_dirs = list(site.getsitepackages())
        if site.ENABLE_USER_SITE:
            site_dirs.append(site.getusersitepackages())
    except AttributeError:  # a virtualenv's old site.py
        site_dirs = []
    for directory in site_dirs:
        write("P", os.path.abspath(directory))
    for path, finder in list(sys.path_importer_cache.items()):
        if isinstance(finder, FileFinder) and path:
            write("Q", os.path.abspath(finder.path))
    for name, module in list(sys.modules.items()):
        _looked_up(write, name, module)

    original_fill, original_find = FileFinder._fill_cache, FileFinder.find_spec

    def fill_cache(self):
        os.environ["WSOBSERVE_QUIET"] = "1"
        try:
            return original_fill(self)
        finally:
            try:
                del os.environ["WSOBSERVE_QUIET"]
            except KeyError:
                pass
            write("Q", self.path)

    def find_spec(self, fullname, target=None):
        write("K", f"{self.path}\x1f{fullname.rpartition('.')[2]}")
        return original_find(self, fullname, target)

    FileFinder._fill_cache = fill_cache
    FileFinder.find_spec = find_spec


def _looked_up(write, name, module):
    """A module imported before the hook: looked up in each directory of its search path up
    to the one it came from."""
    spec = getattr(module, "__spec__", None)
    origin = getattr(spec, "origin", None) if spec is not None else None
    if not isinstance(origin, str) or not os.path.isabs(origin):
        return
    parent, _, tail = name.rpartition(".")
    if parent:
        package = sys.modules.get(parent)
        search = list(getattr(package, "__path__", None) or ())
    else:
        search = list(sys.path)
    location = os.path.dirname(origin)
    if getattr(spec, "submodule_search_locations", None):
        location = os.path.dirname(location)
    for directory in search:
        directory = os.path.abspath(directory or ".")
        write("K", f"{directory}\x1f{tail}")
        if directory == location:
            break


def _next_sitecustomize():
    """The sitecustomize this one stands in front of, if any."""
    here = os.path.dirname(os.path.abspath(__file__))
    sys.path[:] = [p for p in sys.path if os.path.abspath(p or ".") != here]
    module = sys.modules.pop(__name__, None)
    try:
        import importlib

        importlib.import_module("sitecustomize")
    except ImportError:
        if module is not None:
            sys.modules[__name__] = module


if __name__ == "sitecustomize":
    _observe()
    _next_sitecustomize()
