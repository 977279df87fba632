"""A package's record (wsbuild/record/): its own files by one rule, what its steps read
outside by content, the variables they read by digest, the two keys, and the one dirty check.
Pure logic on real files in tmp_path; the builds that write and read records are
tests/test_up_to_date.py's and tests/test_observed.py's."""

from __future__ import annotations

import json
import os
import time
from pathlib import Path

import pytest

from wsbuild import inputs
from wsbuild.record.dirty import Environment, PackageNow, dirty_reason
from wsbuild.record.environment import UNSET, changed_names, variable_digests
from wsbuild.record.installed import Installed, damaged_install, installed_entries
from wsbuild.record.model import PackageRecord, PackedReadBy, read_record, write_record
from wsbuild.record.outside import Digests, first_change, own_entries, take
from wsbuild.record.own_files import LEFT_OUT, own_files


def _write(path: Path, text: str = "x") -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def test_no_directory_is_skipped_for_its_name_but_vcs_and_the_test_caches(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    for rel in ("setup.py", "pkg/log/__init__.py", "test/log/sample.log", "build/notes.txt",
                "install/model.yaml", "vendor/COLCON_IGNORE", "vendor/v.cpp", ".clang-format",
                ".git/HEAD", "pkg/__pycache__/m.cpython-311.pyc", ".pytest_cache/v/x",
                "notes.txt~", "pkg/egg.egg-info/PKG-INFO"):
        _write(pkg / rel)
    ws_build = tmp_path / "pkg" / "ws_build_base"  # a workspace base inside the package
    _write(ws_build / "pkg" / "CMakeCache.txt")
    files = own_files(pkg, {}, outputs=[str(ws_build)]).files
    assert sorted(files) == [".clang-format", "build/notes.txt", "install/model.yaml",
                             "notes.txt~", "pkg/egg.egg-info/PKG-INFO", "pkg/log/__init__.py",
                             "setup.py", "test/log/sample.log", "vendor/COLCON_IGNORE",
                             "vendor/v.cpp"]
    assert LEFT_OUT == {".git", ".hg", ".svn", ".bzr", "CVS", "__pycache__", ".pytest_cache"}


def test_a_file_is_hashed_only_when_its_signature_changed(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    main = _write(pkg / "main.py", "A = 1\n")
    first = own_files(pkg, {})
    os.utime(main)  # touched: a new signature, the same content
    touched = own_files(pkg, first.files)
    assert touched.digest == first.digest and touched.changed == []
    _write(main, "A = 2\n")
    edited = own_files(pkg, touched.files)
    assert edited.digest != first.digest and edited.changed == ["main.py"]
    # a stale digest under an unchanged signature is trusted: no read when nothing changed
    stale = {"main.py": edited.files["main.py"].__class__(
        *[*edited.files["main.py"].as_list()[:2], "stale", *edited.files["main.py"].as_list()[3:]])}
    assert own_files(pkg, stale).files["main.py"].digest == "stale"


def test_a_symlink_counts_by_its_target_and_where_it_points(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    a, b = _write(tmp_path / "a.txt", "same\n"), _write(tmp_path / "b.txt", "same\n")
    pkg.mkdir()
    (pkg / "link.txt").symlink_to(a)
    first = own_files(pkg, {})
    (pkg / "link.txt").unlink()
    (pkg / "link.txt").symlink_to(b)
    assert own_files(pkg, first.files).digest != first.digest  # same content, other target


def test_outside_reads_are_compared_by_content_and_listings_by_entries(tmp_path: Path) -> None:
    header = _write(tmp_path / "inc" / "ext.h", "#define A 1\n")
    globbed = tmp_path / "globbed"
    _write(globbed / "a.txt")
    digests = Digests()
    reads = take([str(header)], [str(globbed)], digests)
    assert first_change(reads, Digests()) is None
    os.utime(header)  # another signature, the same content: unchanged
    assert first_change(reads, Digests()) is None
    _write(globbed / "a.txt", "edited")  # an entry's content is no listing's
    assert first_change(reads, Digests()) is None
    _write(globbed / "b.txt")
    assert first_change(reads, Digests()) == str(globbed)
    (globbed / "b.txt").unlink()
    _write(header, "#define A 2\n")
    assert first_change(reads, Digests()) == str(header)


def test_a_file_that_changed_while_the_build_ran_is_held_as_racy(tmp_path: Path) -> None:
    header = _write(tmp_path / "ext.h")
    reads = take([str(header)], [], Digests(), started_ns=0)
    assert first_change(reads, Digests()) is None
    racy = take([str(header)], [], Digests(), started_ns=header.stat().st_mtime_ns)
    assert first_change(racy, Digests()) == str(header)


def test_a_listing_leaves_out_the_entries_the_package_installs_itself(tmp_path: Path) -> None:
    """In a merged install, install/'s directories hold every package's files: a package's
    own entries are no input of its own build."""
    install = tmp_path / "install"
    site = install / "lib" / "site-packages"
    _write(site / "dep" / "__init__.py")
    own = own_entries(str(install), [("lib/site-packages/me/__init__.py", (), "")])
    reads = take([], [str(site)], Digests(), own=own)
    _write(site / "me" / "__init__.py")
    assert first_change(reads, Digests(), own=own) is None
    _write(site / "other" / "__init__.py")
    assert first_change(reads, Digests(), own=own) == str(site)


def test_a_record_holds_the_variables_read_whatever_their_name_by_digest() -> None:
    env = {"PATH": "/bin", "TURTLEBOT3_MODEL": "burger", "BUILD_NUMBER": "7",
           "HOME": "/home/a", "TOKEN": "s3cr3t", "EDITOR": "vim"}
    digests = variable_digests(env, ["HOME", "TOKEN", "BUILD_NUMBER", "UNSET_ONE",
                                     "WSBUILD_CACHE_DIR"])
    assert sorted(digests) == ["BUILD_NUMBER", "HOME", "TOKEN", "UNSET_ONE"]
    assert digests["UNSET_ONE"] == UNSET
    assert "s3cr3t" not in json.dumps(digests)
    other = variable_digests({**env, "HOME": "/home/b", "EDITOR": "emacs"}, digests)
    assert changed_names(digests, other) == ["HOME"]
    # a path list's entries in the workspace's own install go; a single path into it counts
    sourced = {"AMENT_PREFIX_PATH": "/ws/install/a:/opt/ros", "MY_MAP": "/ws/install/a/m.yaml"}
    plain = {"AMENT_PREFIX_PATH": "/opt/ros", "MY_MAP": "/ws/install/b/m.yaml"}
    names = ["AMENT_PREFIX_PATH", "MY_MAP"]
    a = variable_digests(sourced, names, own_install="/ws/install")
    b = variable_digests(plain, names, own_install="/ws/install")
    assert changed_names(a, b) == ["MY_MAP"]


def test_an_installed_file_is_checked_by_content_and_a_link_by_where_it_points(
        tmp_path: Path) -> None:
    install = tmp_path / "install"
    data = _write(install / "p" / "share" / "data.txt", "aaaa")
    target = _write(tmp_path / "src" / "p" / "launch.py", "x")
    (install / "p" / "launch.py").symlink_to(target)
    installed = installed_entries(str(install), [str(data), str(install / "p" / "launch.py")])
    assert damaged_install(str(install), installed) is None
    data.write_text("bbbb")  # edited in place, its size kept
    assert damaged_install(str(install), installed) == "p/share/data.txt"
    data.write_text("aaaa")
    assert damaged_install(str(install), installed) is None
    target.rename(tmp_path / "src" / "moved.py")  # the package moved: the link dangles
    assert damaged_install(str(install), installed) == "p/launch.py"


def _record(own: Path, **fields: object) -> PackageRecord:
    values: dict[str, object] = dict(package="p", build_type="cmake",
                                     own=own_files(own, {}).files, settings={"options": {}},
                                     environment=variable_digests({"PATH": "x"}, ["PATH"]),
                                     dependencies={"d": "k1"},
                                     dependency_inputs={"d": "i1"}, complete=True)
    values.update(fields)
    return PackageRecord(**values).sealed()  # type: ignore[arg-type]


def test_the_keys_derive_from_the_record_and_a_record_round_trips(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    _write(pkg / "CMakeLists.txt")
    record = _record(pkg)
    # what the steps read is known after a build only: in the key, not the inputs key
    assert _record(pkg, environment={"PATH": "y"}).inputs_key == record.inputs_key
    assert _record(pkg, environment={"PATH": "y"}).key != record.key
    assert _record(pkg, dependencies={"d": "k2"}).inputs_key == record.inputs_key
    assert _record(pkg, dependencies={"d": "k2"}).key != record.key
    header = _write(tmp_path / "ext.h")
    read = _record(pkg, outside=take([str(header)], [], Digests()))
    assert read.inputs_key == record.inputs_key and read.key != record.key
    write_record(tmp_path / "build", read)
    assert read_record(tmp_path / "build") == read
    directory = tmp_path / "build" / ".wsbuild"
    assert directory.stat().st_mode & 0o777 == 0o700
    assert (directory / "record.json").stat().st_mode & 0o777 == 0o600


def test_a_plan_reads_the_records_from_one_memo_while_each_file_is_the_one_it_holds(
        tmp_path: Path) -> None:
    """Records written and read are noted in build/.wsbuild/records.memo (private to the
    user), each with its file's stat signature; a later process takes the record from the
    memo, with what two records read outside held once, until its file is replaced."""
    from wsbuild.record import memo

    base = tmp_path / "build"
    header = _write(tmp_path / "ext.h")
    records = {}
    for name in ("a", "b"):
        pkg = _write(tmp_path / name / "CMakeLists.txt").parent
        records[name] = _record(pkg, outside=take([str(header)], [], Digests()),
                                read_by={str(header): "configure,build"},
                                installed=(Installed(f"{name}/lib/lib{name}.so",
                                                     (33188, 7, 12, 1, 2), "d1"),
                                           Installed(f"{name}/lib/lib{name}.so.1",
                                                     (41471, 8, 9, 3, 4), "->lib.so")))
        write_record(base / name, records[name])
    memo.save_memos()
    path = base / memo.MEMO_FILE
    assert path.stat().st_mode & 0o777 == 0o600
    memo._memos.clear()  # a new process
    loaded = memo.memo_of(base, 2)
    for name, record in records.items():
        held = loaded.get(name, inputs.signature(base / name / ".wsbuild" / "record.json"))
        assert held is not None and held[1] == record.outside
        assert read_record(base / name) == record  # its installed files too, as Installed
        assert all(type(i) is Installed for i in read_record(base / name).installed)
        # which steps read a path is unpacked only when asked (a package that changed)
        read_by = read_record(base / name).read_by  # type: ignore[union-attr]
        assert isinstance(read_by, PackedReadBy)
        assert read_by[str(header)] == "configure,build" and list(read_by) == [str(header)]
    first, second = (loaded.get(n, inputs.signature(base / n / ".wsbuild" / "record.json"))
                     for n in ("a", "b"))
    assert first is not None and second is not None
    assert first[1].files[str(header)] is second[1].files[str(header)]  # held once
    # another record in a's file: read from the file, not the memo
    changed = _record(tmp_path / "a", environment={"PATH": "other"})
    write_record(base / "a", changed)
    memo._memos.clear()
    assert read_record(base / "a") == changed


def test_the_one_dirty_check_names_what_changed_first(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    _write(pkg / "CMakeLists.txt")
    header = _write(tmp_path / "ext.h", "1")
    old = _record(pkg, outside=take([str(header)], [], Digests()))

    def reason(**now: object) -> str | None:
        values: dict[str, object] = dict(own=own_files(pkg, old.own), settings=old.settings,
                                         environment=Environment({"PATH": "x"}),
                                         dependencies=old.dependencies)
        values.update(now)
        found = dirty_reason(old, PackageNow(**values),  # type: ignore[arg-type]
                             install_base=tmp_path / "install", digests=Digests(),
                             pending=("d",))
        return None if found is None else found.kind + ": " + found.text

    assert reason() is None
    assert reason(environment=Environment({"PATH": "y"})) == \
        "environment: environment variable changed: PATH"
    assert reason(environment=Environment({"PATH": "x", "EDITOR": "vim"})) is None
    assert reason(settings={"options": {"cmake_args": ["-DX=1"]}}).startswith("options:")
    assert reason(dependencies={"d": "pending:x"}).startswith("dependency: dependency d is built first")
    _write(header, "2")
    assert reason() == f"external: file outside the package changed: {header}"
    _write(pkg / "CMakeLists.txt", "edited")
    assert reason() == "source: source changed: CMakeLists.txt"
    assert dirty_reason(None, PackageNow(own_files(pkg, {}), {}, Environment({}), {}),
                        install_base=tmp_path, digests=Digests()).kind == "new"
    assert reason(environment=Environment({"PATH": "x"})) is not None  # (the source edit)
    _write(pkg / "CMakeLists.txt")
    incomplete = _record(pkg, outside=take([str(header)], [], Digests()), complete=False,
                         unobserved=("/bin/static ran unobserved",))
    now = PackageNow(own_files(pkg, incomplete.own), incomplete.settings,
                     Environment({"PATH": "x"}), incomplete.dependencies)
    assert dirty_reason(incomplete, now, install_base=tmp_path, digests=Digests()).kind == \
        "unobserved"
    # a dependency built first in this run, under a package whose record is incomplete: it is
    # built, never cut off (what its unobserved steps read of the dependency is not known)
    rebuilt = dirty_reason(incomplete, PackageNow(now.own, now.settings, now.environment,
                                                  {"d": "pending:k2"}),
                           install_base=tmp_path, digests=Digests(), pending=("d",))
    assert rebuilt is not None and (rebuilt.kind, rebuilt.cutoff) == ("dependency", False)
    # a workspace dependency that was not one at the last build (it joined the workspace):
    # built, never cut off (the last build read it from elsewhere, or not at all)
    joined = dirty_reason(old, PackageNow(own_files(pkg, old.own), old.settings,
                                          Environment({"PATH": "x"}),
                                          {**old.dependencies, "e": "pending:k3"}),
                          install_base=tmp_path, digests=Digests(), pending=("e",))
    assert joined is not None and (joined.kind, joined.cutoff) == ("dependency", False)
    volatile = _record(pkg, outside=take([str(header)], [], Digests()),
                       volatile="custom target version_header always runs")
    assert dirty_reason(volatile, now, install_base=tmp_path, digests=Digests()).kind == \
        "volatile"


def test_every_shortcut_asks_the_one_dirty_check() -> None:
    """Issue 38: one dirty check, in record/dirty.py, with a typed reason (`Dirty`). Planning
    (the no-op decision, `--dry-run`, the replay's plan) asks `dirty_reason`; early cutoff and
    the cache's restore proof ask `changed_read`; nothing else compares a record with now."""
    import ast

    from wsbuild.record.dirty import Dirty

    package = Path(__file__).resolve().parent.parent / "wsbuild"
    askers: dict[str, set[str]] = {}
    for path in package.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                    and node.func.id in ("dirty_reason", "changed_read"):
                askers.setdefault(node.func.id, set()).add(str(path.relative_to(package)))
    # (builder/changed_since.py: `wsbuild test` asks of a package's own files alone)
    assert askers == {"dirty_reason": {"builder/plan.py", "builder/changed_since.py"},
                      "changed_read": {"builder/records.py", "cache/run.py"}}
    assert {kind.value for kind in Dirty} >= {"source", "environment", "dependency", "options"}


def test_a_files_digest_is_kept_across_runs_only_for_its_signature_and_never_racy(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """record/file_digests.py: a digest taken by one run serves the next (another process,
    another workspace) for the same stat signature; a file changed too shortly before its
    digest was taken (within the file system's time granularity) is never kept."""
    from wsbuild.record import file_digests
    from wsbuild.record.file_digests import FileDigests

    monkeypatch.setattr(file_digests, "RACY_NS", 200_000_000)  # the suite's 0.2 s
    old = _write(tmp_path / "old.h", "int a;\n")
    time.sleep(0.3)  # its times (the change time too) before the racy window
    fresh = _write(tmp_path / "fresh.h", "int b;\n")
    memo = FileDigests(tmp_path / "cache" / "digests.memo")
    now = time.time_ns()
    digests = Digests()
    digests.kept = memo
    for path in (old, fresh):
        digests.file(str(path), inputs.signature(path))
    memo.save()
    assert (tmp_path / "cache" / "digests.memo").stat().st_mode & 0o777 == 0o600
    later = FileDigests(tmp_path / "cache" / "digests.memo")  # the next run
    assert later.get(str(old), inputs.signature(old)) == Digests().file(
        str(old), inputs.signature(old))
    assert later.get(str(fresh), inputs.signature(fresh)) is None  # changed < RACY_NS before
    assert inputs.signature(fresh)[4] > now - file_digests.RACY_NS
    old.write_text("int c;\n")  # same size, another signature
    assert later.get(str(old), inputs.signature(old)) is None


def test_what_a_record_read_of_its_dependencies_is_their_keys_here(tmp_path: Path) -> None:
    """The build cache's restore proof and early cutoff ask `changed_read` with the keys the
    package's dependencies have here: an entry built against another build of a dependency
    (or against other dependencies) does not hold; one being built in this run is compared
    by what was read of it, later."""
    from wsbuild.record.dirty import changed_read

    pkg = tmp_path / "pkg"
    _write(pkg / "CMakeLists.txt")
    record = _record(pkg)  # built against d at key k1

    def asked(dependencies: dict[str, str]) -> str | None:
        found = changed_read(record, digests=Digests(), install_base=tmp_path / "install",
                             planning=True, dependencies=dependencies)
        return None if found is None else f"{found.kind}: {found.text}"

    assert asked({"d": "k1"}) is None
    assert asked({"d": "k2"}) == "dependency: built against another build of d"
    assert asked({"d": "pending:k2"}) is None
    assert asked({"d": "k1", "e": "k9"}) == "dependency: built against another build of e"
    assert asked({}) == "dependency: built against other dependencies"


def test_a_cache_entry_whose_record_is_of_other_inputs_is_never_proven(tmp_path: Path) -> None:
    """The build cache's restore proof: an entry found under a package's key whose record says
    other inputs (a corrupted or foreign entry) is never restored; the same record, of these
    inputs, is."""
    import json

    from wsbuild.cache.client import Found
    from wsbuild.cache.run import OTHER_INPUTS, Disproof, disproof
    from wsbuild.record.model import encode

    pkg = tmp_path / "pkg"
    _write(pkg / "CMakeLists.txt")
    record = _record(pkg)
    found = Found(record=None, from_local=True,  # type: ignore[arg-type]
                  package_record=json.dumps(encode(record)).encode())

    def proof(inputs_key: str) -> object:
        return disproof(found, inputs_key, dict(record.dependencies), Digests(),
                        install_base=tmp_path / "install", planning=True)

    assert not isinstance(proof(record.inputs_key), Disproof)
    refused = proof("the inputs key of another build")
    assert isinstance(refused, Disproof) and refused.why == OTHER_INPUTS


def test_records_from_the_memo_find_what_changed_as_records_from_their_files_do(
        tmp_path: Path) -> None:
    """A plan looks at each entry the memo holds once, however many records hold it, and at a
    record's entries again only where a signature changed: it finds the same changes as the
    look at every entry of every record (a file's content, a probed name; not a file touched
    with the same content, nor a probed directory that gained another name)."""
    from dataclasses import replace

    from wsbuild.record import memo

    base = tmp_path / "build"
    shared, only_b = _write(tmp_path / "ext" / "shared.h", "1"), _write(tmp_path / "b.h", "1")
    probed = tmp_path / "probed"
    probed.mkdir()
    for name, files in (("a", [shared]), ("b", [shared, only_b]), ("c", [shared])):
        pkg = _write(tmp_path / name / "CMakeLists.txt").parent
        reads = take([str(f) for f in files], [], Digests(), probes={str(probed): ["x.cmake"]})
        write_record(base / name, _record(pkg, outside=reads))
    memo.save_memos()

    def changes() -> dict[str, tuple[str | None, str | None]]:
        """Per record: the first change as the memo's entries find it, and as every entry of
        the record does."""
        memo._memos.clear()  # a new process
        held, plain = Digests(), Digests()
        found = {}
        for name in ("a", "b", "c"):
            record = read_record(base / name)
            assert record is not None and record.outside.held is not None
            found[name] = (first_change(record.outside, held, planning=True),
                           first_change(replace(record.outside, held=None), plain,
                                        planning=True))
        return found

    assert changes() == {n: (None, None) for n in "abc"}
    time.sleep(0.01)
    shared.write_text("1")  # touched: another signature, the same content
    (probed / "other.txt").write_text("")  # the probed directory changed, not the name probed
    assert changes() == {n: (None, None) for n in "abc"}
    only_b.write_text("2")
    assert changes() == {"a": (None, None), "b": (str(only_b), str(only_b)), "c": (None, None)}
    (probed / "x.cmake").write_text("")  # the probed name appears: every record
    assert changes() == {"a": (str(probed),) * 2, "b": (str(only_b),) * 2,
                         "c": (str(probed),) * 2}
