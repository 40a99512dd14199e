"""Every file ldpipe writes goes through ldpipe.io.atomic: the helper's guarantees, and a reading of
the source that finds any other way of writing a file."""

import ast
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from ldpipe.errors import LdpipeError, OutputError
from ldpipe.io.atomic import atomic_path, check_writable, temporary_name, write_or_keep, write_text_atomic

SOURCE = Path(__file__).resolve().parents[1] / "src" / "ldpipe"
HELPER = SOURCE / "io" / "atomic.py"

#: Writes that are not whole files, each with why it may stay: (file under src/ldpipe, function).
ALLOWED = {
    ("jitcache.py", "record_compile_event"): "appends one short line to a log shared by parallel processes; "
                                              "a rename would lose the other processes' lines",
    ("core/maps/zarr_stream.py", "write_region"): "writes one block's region into a zarr store made atomically; "
                                                  "the block's marker is put in place atomically after it, and "
                                                  "a block without one is written again when the stream resumes",
}
WRITING_METHODS = {"write_text", "write_bytes", "savefig", "to_netcdf", "to_zarr"}
WRITING_MODES = set("wax+")


def _mode(call: ast.Call, position: int) -> str | None:
    """The mode of an ``open``-like call: its positional argument at ``position`` or ``mode=``."""
    for keyword in call.keywords:
        if keyword.arg == "mode":
            return keyword.value.value if isinstance(keyword.value, ast.Constant) else "?"
    if len(call.args) > position:
        argument = call.args[position]
        return argument.value if isinstance(argument, ast.Constant) and isinstance(argument.value, str) else "?"
    return None


def _is_os(func) -> bool:
    return isinstance(func, ast.Attribute) and isinstance(func.value, ast.Name) and func.value.id == "os"


def _called(call, name: str) -> bool:
    func = call.func if isinstance(call, ast.Call) else None
    return (isinstance(func, ast.Name) and func.id == name) or (isinstance(func, ast.Attribute) and func.attr == name)


def _target(call: ast.Call, name: str):
    """The expression naming the file a writing call writes."""
    func = call.func
    if name in ("write_text", "write_bytes") or (name == "open" and isinstance(func, ast.Attribute)):
        return func.value
    return call.args[0] if call.args else None


def direct_writes(path: Path, relative: str) -> list[str]:
    """Each place in ``path``'s source that writes a file itself, as "FILE:LINE: what".

    Writing to the temporary the helper hands out is the helper's way: a name bound by
    ``with atomic_path(...) as NAME``, or the parameter of a function given to ``write_or_keep``.
    """
    tree = ast.parse(path.read_text(), filename=str(path))
    writers = {node.args[1].id for node in ast.walk(tree) if isinstance(node, ast.Call) and _called(node, "write_or_keep")
               and len(node.args) > 1 and isinstance(node.args[1], ast.Name)}
    found = []

    def visit(node, function, temporaries):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                inner = set(temporaries)
                if child.name in writers and child.args.args:
                    inner.add(child.args.args[0].arg)
                visit(child, child.name, inner)
                continue
            if isinstance(child, (ast.With, ast.AsyncWith)):
                visit(child, function, temporaries | {item.optional_vars.id for item in child.items
                                                      if _called(item.context_expr, "atomic_path")
                                                      and isinstance(item.optional_vars, ast.Name)})
                continue
            if isinstance(child, ast.Call):
                what = None
                func = child.func
                name = func.attr if isinstance(func, ast.Attribute) else func.id if isinstance(func, ast.Name) else None
                if name in WRITING_METHODS and isinstance(func, ast.Attribute):
                    what = f".{name}(...)"
                elif name == "open" and not _is_os(func):  # os.open takes flags: descriptors for locks and fsync
                    # open(path, mode), io.open(path, mode) or Path(...).open(mode)
                    method = isinstance(func, ast.Attribute) and not (isinstance(func.value, ast.Name)
                                                                      and func.value.id == "io")
                    mode = _mode(child, 0 if method else 1)
                    if mode is not None and (mode == "?" or WRITING_MODES & set(mode)):
                        what = f"open(..., {mode!r})"
                elif name in ("replace", "rename") and _is_os(func):
                    what = f"os.{name}(...)"
                    name = None  # never to a temporary: putting files in place is the helper's
                if what and name is not None:
                    target = _target(child, name)
                    if isinstance(target, ast.Call) and _called(target, "str") and target.args:
                        target = target.args[0]
                    if isinstance(target, ast.Name) and target.id in temporaries:
                        what = None
                if what and (relative, function) not in ALLOWED:
                    found.append(f"src/ldpipe/{relative}:{child.lineno}: {what} in {function or 'the module'}; "
                                 "write files through ldpipe.io.atomic (atomic_path, write_text_atomic)")
            visit(child, function, temporaries)

    visit(tree, None, frozenset())
    return found


def all_direct_writes(root: Path = SOURCE) -> list[str]:
    found = []
    for path in sorted(root.rglob("*.py")):
        if path.resolve() == HELPER.resolve() or path.relative_to(root) == Path("io/atomic.py"):
            continue
        found += direct_writes(path, path.relative_to(root).as_posix())
    return found


def test_no_module_writes_a_file_but_through_the_helper():
    found = all_direct_writes()
    assert not found, "\n".join(found)


@pytest.mark.parametrize("line", [
    'Path("x").write_text("a")', 'open(p, "w").write("a")', 'open(p, mode="ab")', 'p.open("w")',
    'ds.to_netcdf(p)', 'fig.savefig(p)', 'os.replace(a, b)', 'ds.to_zarr(p)', 'p.write_bytes(b"")',
])
def test_the_source_check_finds_a_seeded_direct_write(tmp_path, line):
    """A scratch copy of the package with one direct write seeded: the check names its file and line."""
    copy = tmp_path / "ldpipe"
    subprocess.run(["cp", "-r", str(SOURCE), str(copy)], check=True)
    target = copy / "stages" / "equilibria.py"
    lines = target.read_text().splitlines()
    lines.insert(10, line)
    target.write_text("\n".join(lines) + "\n")
    found = all_direct_writes(copy)
    assert len(found) == 1 and found[0].startswith("src/ldpipe/stages/equilibria.py:11: "), found


def test_reading_is_not_a_write(tmp_path):
    module = tmp_path / "m.py"
    module.write_text('open(p)\nopen(p, "rb")\nPath(p).open()\nos.open(p, os.O_RDONLY)\nwith open(p, "r") as f: pass\n')
    assert direct_writes(module, "m.py") == []


def test_writing_the_helpers_temporary_is_allowed_and_nothing_else(tmp_path):
    module = tmp_path / "m.py"
    module.write_text("with atomic_path(p) as temporary:\n    temporary.write_text('a')\n"
                      "    ds.to_netcdf(temporary)\n    other.write_text('b')\n"
                      "def write(scratch):\n    ds.to_netcdf(scratch)\nwrite_or_keep(p, write)\n"
                      "temporary.write_text('c')\n")
    assert [line.split(": ")[0] for line in direct_writes(module, "m.py")] == ["src/ldpipe/m.py:4", "src/ldpipe/m.py:8"]


def test_a_file_appears_whole_and_leaves_nothing_beside_it(tmp_path):
    path = tmp_path / "deep" / "out.txt"
    write_text_atomic(path, "new\n")
    assert path.read_text() == "new\n"
    assert sorted(p.name for p in path.parent.iterdir()) == ["out.txt"]


@pytest.mark.parametrize("error", [ValueError("bad data"), KeyboardInterrupt()])
def test_a_failed_write_leaves_the_previous_file_and_no_temporary(tmp_path, error):
    path = tmp_path / "out.txt"
    path.write_text("old\n")
    with pytest.raises(type(error)):
        with atomic_path(path) as temporary:
            temporary.write_text("half")
            raise error
    assert path.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]


def test_an_os_error_while_writing_names_the_path(tmp_path):
    path = tmp_path / "out.nc"
    with pytest.raises(OutputError, match=rf"^{path}: could not be written \(writing: No space left on device\)"):
        with atomic_path(path):
            raise OSError(28, "No space left on device")
    assert list(tmp_path.iterdir()) == []
    assert issubclass(OutputError, LdpipeError) and issubclass(OutputError, OSError)


def test_a_folder_that_cannot_be_made_names_the_path(tmp_path):
    (tmp_path / "file").write_text("")
    path = tmp_path / "file" / "out.nc"
    with pytest.raises(OutputError, match=rf"^{path}: could not be written \(making its folder"):
        with atomic_path(path):
            pytest.fail("the block must not run")


def test_without_replace_a_file_put_there_meanwhile_is_kept(tmp_path):
    path = tmp_path / "module.py"
    with atomic_path(path, replace=False) as temporary:
        temporary.write_text("mine")
        path.write_text("theirs")  # another process linked its copy first
    assert path.read_text() == "theirs"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["module.py"]


def test_temporaries_are_hidden_unique_per_thread_and_end_in_tmp(tmp_path):
    names = []
    thread = threading.Thread(target=lambda: names.append(temporary_name(tmp_path / "a.nc")))
    thread.start()
    thread.join()
    mine = temporary_name(tmp_path / "a.nc")
    assert mine != names[0]
    assert mine.name.startswith(".a.nc.") and mine.name.endswith(".tmp") and f"-{os.getpid()}-" in mine.name
    assert not list(tmp_path.glob("*.nc"))  # never taken for a file of the kind by a glob
    assert temporary_name(tmp_path / "a.gif", keep_suffix=True).name.endswith(".tmp.gif")  # for Pillow


@pytest.mark.parametrize("keep_suffix", [False, True])
def test_temporaries_of_killed_writers_are_removed_on_the_next_write(tmp_path, keep_suffix):
    path = tmp_path / "out.nc"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True,
                          check=True)
    mine = str(temporary_name(path, keep_suffix=keep_suffix))
    stale = Path(mine.replace(f"-{os.getpid()}-", f"-{int(dead.stdout)}-"))
    stale.write_text("half")
    alive = Path(mine.replace(f"-{os.getpid()}-", f"-{os.getppid()}-"))
    alive.write_text("being written")  # a live process's: left alone
    other = tmp_path / f".out.nc.otherhost-{int(dead.stdout)}-1.tmp"
    other.write_text("another host's")  # its pid means nothing here: left alone
    write_text_atomic(path, "whole")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([alive.name, other.name, "out.nc"])


def test_check_writable_names_the_path_when_a_parent_is_a_file(tmp_path):
    (tmp_path / "file").write_text("")
    path = tmp_path / "file" / "sub" / "out.nc"
    with pytest.raises(OutputError, match=rf"^{path}: cannot write the output there: {tmp_path / 'file'} is a file"):
        check_writable(path)


def test_check_writable_refuses_a_folder_and_makes_nothing(tmp_path):
    with pytest.raises(OutputError, match="it is a folder"):
        check_writable(tmp_path)
    check_writable(tmp_path / "new" / "out.nc", None, tmp_path / "other.png")
    assert list(tmp_path.iterdir()) == []


def test_a_failed_write_keeps_the_result_in_the_temporary_folder(tmp_path, monkeypatch):
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    monkeypatch.setattr("tempfile.tempdir", str(scratch))
    (tmp_path / "gone").write_text("")  # the output's folder was replaced by a file during the run
    path = tmp_path / "gone" / "out.txt"
    with pytest.raises(OutputError) as raised:
        write_or_keep(path, lambda temporary: temporary.write_text("result"))
    kept = scratch / f"ldpipe-kept-{os.getpid()}-out.txt"
    assert str(raised.value).startswith(f"{path}: could not be written")
    assert str(raised.value).endswith(f"; the result is kept in {kept}")
    assert kept.read_text() == "result"


def test_when_nothing_can_be_kept_the_message_says_so(tmp_path, monkeypatch):
    (tmp_path / "file").write_text("")
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path / "file" / "tmp"))
    with pytest.raises(OutputError, match="; nothing was written \\(keeping the result in .* failed too"):
        write_or_keep(tmp_path / "file" / "out.txt", lambda temporary: temporary.write_text("result"))


def test_an_output_error_from_inside_is_not_wrapped_again(tmp_path):
    with pytest.raises(OutputError, match=r"^inner: could not be written$"):
        with atomic_path(tmp_path / "out.nc"):
            raise OutputError("inner: could not be written")
    assert list(tmp_path.iterdir()) == []
