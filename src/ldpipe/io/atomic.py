"""Every file ldpipe writes goes through here: written under a temporary name beside it, then
renamed into place, so a reader (or the next run) sees the previous file or the complete new
one, never a truncated one, whenever the writing process is killed.

- :func:`atomic_path` — a context manager yielding the temporary path to write; on success the
  file is flushed to disk and renamed over ``path``; on any exception (Ctrl-C included) it is
  removed and ``path`` is untouched.
- :func:`write_text_atomic` — text, through :func:`atomic_path`.
- :func:`check_writable` — whether a file can be written at ``path``, asked before the work
  that makes it, so an hour of integration is never thrown away at the end.
- :func:`write_or_keep` — a write that, when it fails at the end (the disk filled), puts the
  result in the system's temporary folder instead and names it in the error.

``tests/test_atomic_writes.py`` checks, by reading the source, that no other module writes a
file any other way.
"""

from __future__ import annotations

import contextlib
import os
import re
import socket
import tempfile
import threading
from pathlib import Path
from typing import Callable, Iterator

from ..errors import OutputError

#: Ends every temporary name, so that no glob for a kind of file (``*.nc``, as
#: :mod:`ldpipe.io.filediff` compares two folders of results) takes a killed writer's leftover for one. A writer that reads
#: the format from the name (Pillow's GIF writer) asks for the target's suffix after it.
TEMPORARY_MARK = ".tmp"


def _host() -> str:
    return re.sub(r"[^A-Za-z0-9_.]", "_", socket.gethostname()) or "host"


def temporary_name(path: str | os.PathLike, *, keep_suffix: bool = False) -> Path:
    """The temporary file :func:`atomic_path` writes for ``path``: hidden, beside it, unique to
    this host, process and thread (``.NAME.HOST-PID-THREAD.tmp``, then ``path``'s suffix if
    ``keep_suffix``)."""
    path = Path(path)
    suffix = path.suffix if keep_suffix else ""
    return path.with_name(f".{path.name}.{_host()}-{os.getpid()}-{threading.get_ident()}{TEMPORARY_MARK}{suffix}")


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process
        return True
    return True


def remove_stale_temporaries(path: str | os.PathLike) -> list[Path]:
    """Remove the temporaries of ``path`` left by processes of this host that were killed
    mid-write (their process is gone), and return them. Those of live processes, or of other
    hosts sharing the folder, are left alone: they may be writing now."""
    path = Path(path)
    pattern = re.compile(rf"^\.{re.escape(path.name)}\.{re.escape(_host())}-(\d+)-\d+"
                         rf"{re.escape(TEMPORARY_MARK)}({re.escape(path.suffix)})?$")
    removed = []
    try:
        candidates = list(path.parent.glob(f".{glob_escape(path.name)}.*{TEMPORARY_MARK}*"))
    except OSError:
        return removed
    for candidate in candidates:
        match = pattern.match(candidate.name)
        if match and int(match.group(1)) != os.getpid() and not _pid_alive(int(match.group(1))):
            with contextlib.suppress(OSError):
                candidate.unlink()
                removed.append(candidate)
    return removed


def glob_escape(name: str) -> str:
    """``name`` with glob's special characters taken literally."""
    return re.sub(r"([*?\[])", r"[\1]", name)


def _fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_folder(folder: Path) -> None:
    # The rename itself is durable only once the folder's entry is on disk; best effort (some
    # file systems refuse to open a folder for this).
    with contextlib.suppress(OSError):
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _failed(path: Path, error: BaseException, doing: str) -> OutputError:
    reason = error.strerror if isinstance(error, OSError) and error.strerror else str(error) or type(error).__name__
    return OutputError(f"{path}: could not be written ({doing}: {reason})")


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, replace: bool = True, fsync: bool = True,
                keep_suffix: bool = False) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` to write the file to; put it in place when the
    block ends without an exception.

    Parameters
    ----------
    path : path
        The file to write. Its folder is made if missing.
    replace : bool
        True: the new file replaces whatever is at ``path`` (``os.replace``, atomic on POSIX).
        False: it is hard-linked into place only if nothing is there by then; a file another
        process put there meanwhile is kept (the generated-source cache, whose files are named
        by their text's hash and must keep their modification time).
    fsync : bool
        Flush the file to disk before the rename, so that after a power cut the name never
        points at unwritten blocks.
    keep_suffix : bool
        End the temporary's name with ``path``'s suffix, for a writer that takes the format from
        the name.

    Raises
    ------
    OutputError
        naming ``path``, if the folder cannot be made or the file cannot be written, flushed or
        renamed (``OSError`` of the block's own writing included: a full disk, a missing
        folder). The temporary is removed; the file at ``path`` is left as it was.
    """
    path = Path(path)
    temporary = temporary_name(path, keep_suffix=keep_suffix)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise _failed(path, error, f"making its folder {path.parent}") from error
    try:
        try:
            yield temporary
        except OutputError:  # already names its path
            raise
        except OSError as error:
            raise _failed(path, error, "writing") from error
        try:
            if fsync:
                _fsync_file(temporary)
            if replace:
                os.replace(temporary, path)
            else:
                try:
                    os.link(temporary, path)
                except FileExistsError:  # put there meanwhile by another process: kept
                    pass
                except OSError:  # a file system without hard links
                    os.replace(temporary, path)
        except OSError as error:
            raise _failed(path, error, "putting it in place") from error
        if fsync:
            _fsync_folder(path.parent)
    finally:  # also on KeyboardInterrupt and SystemExit
        with contextlib.suppress(OSError):
            temporary.unlink()
    remove_stale_temporaries(path)


def write_text_atomic(path: str | os.PathLike, text: str, *, newline: str | None = None) -> Path:
    """Write ``text`` to ``path`` through :func:`atomic_path`; ``newline`` as :func:`open`'s."""
    path = Path(path)
    with atomic_path(path) as temporary, open(temporary, "w", newline=newline) as handle:
        handle.write(text)
    return path


def check_writable(*paths: str | os.PathLike | None) -> None:
    """Check that a file can be written at each of ``paths`` (None: skipped), before the work
    that makes them.

    The nearest folder of a path that exists must be a folder ldpipe can create files in (a
    probe file is made there and removed: the only test a root user, a read-only mount or an
    ACL cannot fool), and the path must not be a folder. Folders still missing are not made
    here (the write makes them).

    Raises
    ------
    OutputError
        naming the path and what is in the way.
    """
    for path in paths:
        if path is not None:
            _check_writable(Path(path))


def _check_writable(path: Path) -> None:
    if path.is_dir():
        raise OutputError(f"{path}: cannot write the output there: it is a folder; give a file name")
    folder = path.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise OutputError(f"{path}: cannot write the output there: {folder} is a file, not a folder")
    probe = temporary_name(folder / f"{path.name}.probe")
    try:
        with open(probe, "x"):  # a probe, removed at once: not an output file
            pass
    except OSError as error:
        raise OutputError(f"{path}: cannot write the output there: cannot create files in {folder} "
                          f"({error.strerror or error})") from error
    finally:
        with contextlib.suppress(OSError):
            probe.unlink()


def write_or_keep(path: str | os.PathLike, write: Callable[[Path], None]) -> Path:
    """Write a file with ``write(temporary)`` through :func:`atomic_path`; if that fails (the
    disk filled, the folder went away), write it again in the system's temporary folder and
    raise an error naming both, so a long computation's result is not lost.

    Raises
    ------
    OutputError
        naming ``path``, why it failed, and where the result was kept (or that keeping it
        failed too, and nothing was written).
    """
    path = Path(path)
    try:
        with atomic_path(path) as temporary:
            write(temporary)
        return path
    except OutputError as error:
        failure = error
    kept = Path(tempfile.gettempdir()) / f"ldpipe-kept-{os.getpid()}-{path.name}"
    try:
        with atomic_path(kept) as temporary:
            write(temporary)
    except OutputError as second:
        raise OutputError(f"{failure}; nothing was written (keeping the result in {kept} failed too: "
                          f"{str(second).split(': ', 1)[-1]})") from failure.__cause__
    raise OutputError(f"{failure}; the result is kept in {kept}") from failure.__cause__
