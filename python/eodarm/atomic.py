"""Files written whole or not at all: each to a temporary sibling, renamed into place when
complete.

Every file eodarm writes goes through here (measurement files, records and campaigns, the
fitted arm, the report, the compensated poses, the residuals, the bundled data sets, the
sweeps of ``eodarm.workspace.store``): an exception, Ctrl-C or a kill at any moment leaves the
previous file whole, or the new one, never a part of either (docs/terminal.md, "Nothing
overwritten without asking").

* :func:`atomic_write` opens one file; :func:`atomic_files` writes several as a group: each
  into ``.NAME.partial-PID`` beside it, flushed to disk (``fsync``), then all renamed into
  place (``os.replace``, one atomic step per file) once the last one is complete; if the
  block raises, the temporaries are removed and nothing is replaced.
* :func:`replace` puts a finished file or directory at its path (a directory over a
  directory in one atomic exchange where Linux allows it).
* :func:`clean_leftovers` removes the temporaries of killed processes (they name their PID).
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import shutil
import signal
import stat
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any, BinaryIO, Literal, TextIO, overload

__all__ = [
    "KILL_AT_ENV",
    "Batch",
    "atomic_files",
    "atomic_write",
    "clean_leftovers",
    "deferred_sigint",
    "replace",
    "temporary",
]

#: Test hook: the name of a point (:func:`_kill_point`) at which the writer kills itself with
#: SIGKILL, so that tests can kill a real process at the dangerous moments without timing.
KILL_AT_ENV = "EODARM_KILL_AT"
#: The temporaries written beside an output, named by their process.
_LEFTOVER = re.compile(r"^\..+\.(?:partial|old)-(?P<pid>\d+)$")


@contextlib.contextmanager
def deferred_sigint() -> Iterator[None]:
    """Hold Ctrl-C until the block is done, then raise it (main thread only).

    For the steps that must not be cut in half: a chunk's data and its record, the rename of
    a result into place.
    """
    if threading.current_thread() is not threading.main_thread() or _deferring:
        yield  # elsewhere, or within a block that already holds it
        return
    got: list[int] = []
    old = signal.signal(signal.SIGINT, lambda signum, frame: got.append(signum))
    _deferring.append(True)
    try:
        yield
    finally:
        _deferring.pop()
        signal.signal(signal.SIGINT, old if old is not None else signal.default_int_handler)
    if got:
        raise KeyboardInterrupt


_deferring: list[bool] = []  # non-empty while the main thread holds Ctrl-C


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()


def _kill_point(name: str) -> None:
    """Die here with SIGKILL when the environment names this point (tests only)."""
    if os.environ.get(KILL_AT_ENV) == name:
        os.kill(os.getpid(), signal.SIGKILL)


def _alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (one of another user counts: it is not ours to judge)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, OverflowError):
        return False
    except PermissionError:
        return True
    return True


def clean_leftovers(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporaries of dead processes in ``folder``: ``.NAME.partial-PID`` (an
    output being written) and ``.NAME.old-PID`` (a previous result renamed aside), where no
    process PID is running. Returns what was removed."""
    gone: list[Path] = []
    try:
        entries = list(Path(folder).iterdir())
    except OSError:
        return gone
    for p in entries:
        m = _LEFTOVER.match(p.name)
        if m and not _alive(int(m["pid"])):
            with contextlib.suppress(OSError):
                _remove(p)
                gone.append(p)
    return gone


def _exchange(a: Path, b: Path) -> bool:
    """Swap the paths ``a`` and ``b`` in one atomic step (Linux ``renameat2`` with
    ``RENAME_EXCHANGE``); False where the system or the filesystem cannot."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        fn = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    at_fdcwd, rename_exchange = -100, 2
    if fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EXDEV):
        return False
    raise OSError(err, os.strerror(err), str(b))


def replace(new: Path, out: Path) -> None:
    """Put ``new`` (a file or a directory) at ``out``. A file over a file is one atomic
    rename; otherwise the two are exchanged atomically and the previous result, now at
    ``new``, is removed: a kill at any moment leaves the old result or the new one at
    ``out``. Where the system cannot exchange, a previous ``out`` is renamed aside to
    ``.OUT.old-PID`` first and removed once ``new`` is in place (a later write into the
    folder removes it if the process died). Ctrl-C waits until it is done."""
    with deferred_sigint():
        if not (out.exists() or out.is_symlink()):
            os.rename(new, out)
            return
        if not out.is_dir() and not new.is_dir():
            os.replace(new, out)  # a file over a file: one atomic rename
            return
        if _exchange(new, out):
            _kill_point("replace-exchanged")
            _remove(new)  # the previous result
            return
        old = out.with_name(f".{out.name}.old-{os.getpid()}")
        os.rename(out, old)
        os.rename(new, out)
        _remove(old)


def temporary(out: str | os.PathLike[str]) -> Path:
    """The temporary sibling an output is written to before it is renamed into place:
    ``.NAME.partial-PID`` (hidden, and removed by :func:`clean_leftovers` once its process
    is gone)."""
    p = Path(out)
    return p.with_name(f".{p.name}.partial-{os.getpid()}")


def _open_temp(tmp: Path, mode: str, encoding: str | None, newline: str | None) -> IO[Any]:
    """A new temporary file, opened for writing (a stale one of this process is replaced)."""
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()
    return open(tmp, mode, encoding=encoding, newline=newline)


def _fsync_path(path: Path) -> None:
    """Flush a written file (or a directory's entries) to disk; where the system cannot (a
    directory on some filesystems), nothing."""
    flags = os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) if path.is_dir() else os.O_RDONLY
    try:
        fd = os.open(path, flags)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


class Batch:
    """Files written as a group (:func:`atomic_files`): each into its temporary sibling,
    all renamed into place when the group is complete."""

    def __init__(self) -> None:
        self._files: list[tuple[Path, Path, IO[Any] | None]] = []

    @overload
    def open(
        self,
        path: str | os.PathLike[str],
        mode: Literal["w"] = "w",
        encoding: str | None = "utf-8",
        newline: str | None = None,
    ) -> TextIO: ...

    @overload
    def open(
        self,
        path: str | os.PathLike[str],
        mode: Literal["wb"],
        encoding: str | None = "utf-8",
        newline: str | None = None,
    ) -> BinaryIO: ...

    def open(
        self,
        path: str | os.PathLike[str],
        mode: str = "w",
        encoding: str | None = "utf-8",
        newline: str | None = None,
    ) -> IO[Any]:
        """An open file whose content will be ``path``'s (``mode`` ``"w"`` or ``"wb"``)."""
        if "b" in mode:
            encoding = None
        out, tmp = self._add(path)
        f = _open_temp(tmp, mode, encoding, newline)
        self._files[-1] = (out, tmp, f)
        return f

    def _add(self, path: str | os.PathLike[str]) -> tuple[Path, Path]:
        out = Path(path)
        if any(o == out for o, _, _ in self._files):
            raise ValueError(f"{out}: written twice in one group")
        if all(o.parent != out.parent for o, _, _ in self._files):
            clean_leftovers(out.parent)  # what a killed writer left here
        tmp = temporary(out)
        self._files.append((out, tmp, None))
        return out, tmp

    def _commit(self) -> None:
        for out, tmp, f in self._files:
            if f is not None:
                f.flush()
                os.fsync(f.fileno())
                f.close()
            with contextlib.suppress(OSError):  # a previous file's permissions are kept
                os.chmod(tmp, stat.S_IMODE(os.stat(out).st_mode))
        _kill_point("atomic-written")
        with deferred_sigint():
            for out, tmp, _ in self._files:
                replace(tmp, out)
            for folder in {out.parent for out, _, _ in self._files}:
                _fsync_path(folder)

    def _discard(self) -> None:
        with deferred_sigint():
            for _, tmp, f in self._files:
                if f is not None:
                    with contextlib.suppress(OSError):
                        f.close()
                with contextlib.suppress(OSError):
                    _remove(tmp)


@contextlib.contextmanager
def atomic_files() -> Iterator[Batch]:
    """Write several files as a group: ``with atomic_files() as batch: f = batch.open(p)``.

    Each is written to ``.NAME.partial-PID`` beside it; when the block ends normally every
    one is flushed to disk and renamed into place (each rename atomic; a previous file keeps
    its permissions). If the block raises (an error, Ctrl-C), every temporary is removed and
    no file is touched. The folders must exist.
    """
    batch = Batch()
    try:
        yield batch
    except BaseException:
        batch._discard()
        raise
    try:
        batch._commit()
    except BaseException:
        batch._discard()
        raise


@contextlib.contextmanager
def atomic_write(
    path: str | os.PathLike[str], encoding: str | None = "utf-8", newline: str | None = None
) -> Iterator[TextIO]:
    """``with atomic_write(path) as f:`` — ``f`` is a text file, a temporary sibling of
    ``path``, renamed over it when the block ends normally; removed, with ``path``
    untouched, if it raises. (Binary files and several at once: :func:`atomic_files`.)"""
    with atomic_files() as batch:
        yield batch.open(path, "w", encoding, newline)
