"""Crash recovery: autosaved copies of open documents, and the backups of saves.

Every running flatweave (one :class:`Session` each) owns one recovery file in
the recovery folder (:func:`recovery_dir`) and holds an exclusive lock on a
lock file beside it for as long as it lives::

    ~/.local/state/flatweave/recovery/
        session-<id>.flatweave   the open document, a normal project file plus
                                 a "recovery" entry (where the document lives,
                                 when it was written, the program's pid)
        session-<id>.lock        locked (flock) by the running session

The kernel drops the lock when the process ends, however it ends, so at the
next start a recovery file whose lock can be taken belongs to a session that
did not close normally: :func:`find_orphans` lists those, newest first, and
the app offers them back. While one is offered its lock is held, so a second
flatweave started meanwhile does not offer the same file. A session that
closes normally removes its files (:meth:`Session.close`).

Writes are atomic (:mod:`flatweave.files`), so a crash during an autosave leaves
the previous autosave. A project is immutable, so an autosave can serialise
it on any thread.

Backups: :func:`save_with_backups` keeps the last few saved versions of a
project beside it as ``<stem>.backup-1.flatweave`` (the newest) up to
``<stem>.backup-N.flatweave``; they are ordinary project files.

The folder is ``$FLATWEAVE_RECOVERY_DIR`` if set, else
``$XDG_STATE_HOME/flatweave/recovery`` (``~/.local/state`` by default).
"""

from __future__ import annotations

import json
import os
import shutil
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

from flatweave.errors import FlatweaveError
from flatweave.files import atomic_write_bytes, json_bytes
from flatweave.document.project import PROJECT_SUFFIX, Project, load_project, project_to_dict

try:  # POSIX; elsewhere a session is alive while its pid is
    import fcntl
except ImportError:  # pragma: no cover - not on Linux
    fcntl = None

__all__ = ["recovery_dir", "Session", "Orphan", "find_orphans", "backup_paths", "save_with_backups",
           "BACKUPS"]

BACKUPS = 3
"""How many earlier saves :func:`save_with_backups` keeps by default."""


def recovery_dir() -> Path:
    """The folder of recovery files (see the module docstring)."""
    env = os.environ.get("FLATWEAVE_RECOVERY_DIR")
    if env:
        return Path(env)
    state = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(state) / "flatweave" / "recovery"


def _lock(path: Path):
    """An open file descriptor holding an exclusive lock on ``path``, or None
    if another process holds it."""
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o600)
    if fcntl is None:  # pragma: no cover
        return fd
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return None
    return fd


def _unlink(path: Path) -> None:
    try:
        path.unlink()
    except OSError:
        pass


class Session:
    """This program's recovery file. ``write`` it as often as wanted; ``close``
    at a normal exit. Raises a one-line FlatweaveError if the folder cannot be
    made (the app then runs without recovery and says so)."""

    def __init__(self, folder: str | os.PathLike | None = None):
        self.folder = Path(folder) if folder is not None else recovery_dir()
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise FlatweaveError(f"cannot make the recovery folder {self.folder}: {exc.strerror or exc}") from None
        self.id = f"{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}-{uuid.uuid4().hex[:6]}"
        self.path = self.folder / f"session-{self.id}{PROJECT_SUFFIX}"
        self.lock_path = self.folder / f"session-{self.id}.lock"
        self._fd = _lock(self.lock_path)
        if self._fd is None:  # pragma: no cover - a fresh random name is never locked
            raise FlatweaveError(f"cannot lock {self.lock_path}")
        self.writes = 0

    def write(self, project: Project, document_path: str | os.PathLike | None = None) -> Path:
        """Autosave ``project`` (which belongs at ``document_path``, if it was
        ever saved) to this session's recovery file, atomically."""
        doc = project_to_dict(project)
        doc["recovery"] = {"document_path": None if document_path is None else os.fspath(document_path),
                           "saved_at": time.time(), "pid": os.getpid()}
        atomic_write_bytes(self.path, json_bytes(doc, self.path))
        self.writes += 1
        return self.path

    def clear(self) -> None:
        """Nothing to recover any more (the document was saved or closed): remove the file."""
        _unlink(self.path)

    def close(self) -> None:
        """A normal exit: remove the recovery file and release the lock."""
        self.clear()
        if self._fd is not None:
            _unlink(self.lock_path)
            os.close(self._fd)
            self._fd = None


@dataclass
class Orphan:
    """A recovery file left by a session that did not close normally.

    path : the recovery file; document_path : where its document was saved
    (None: never saved); saved_at : when it was autosaved (seconds since the
    epoch); name : the project's name. Its lock is held until :meth:`load`
    finishes the recovery, :meth:`discard` or :meth:`release`.
    """

    path: Path
    document_path: Path | None
    saved_at: float
    name: str
    _fd: int | None = None

    def describe(self) -> str:
        when = time.strftime("%Y-%m-%d %H:%M", time.localtime(self.saved_at))
        where = f" ({self.document_path})" if self.document_path else " (never saved)"
        return f"{self.name}{where}, autosaved {when}"

    def load(self) -> Project:
        """The autosaved project (one-line ProjectError if the file is damaged)."""
        return load_project(self.path)

    def discard(self) -> None:
        """Delete the recovery file and its lock."""
        _unlink(self.path)
        lock = self.path.with_suffix(".lock")
        if self._fd is not None:
            _unlink(lock)
        self.release()

    def release(self) -> None:
        """Keep the file for a later start (another flatweave may now offer it)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


def find_orphans(folder: str | os.PathLike | None = None) -> list[Orphan]:
    """Recovery files whose session is gone, newest first, each locked for the
    caller. Files that cannot be read as recovery files are skipped (and left)."""
    folder = Path(folder) if folder is not None else recovery_dir()
    found = []
    for lock in folder.glob("session-*.lock"):  # sessions that ended before their first autosave
        if not lock.with_suffix(PROJECT_SUFFIX).exists():
            fd = _lock(lock)
            if fd is not None:
                _unlink(lock)
                os.close(fd)
    for path in sorted(folder.glob(f"session-*{PROJECT_SUFFIX}")):
        fd = _lock(path.with_suffix(".lock"))
        if fd is None:
            continue  # its session is running
        try:
            with open(path, "rb") as fh:
                doc = json.loads(fh.read())
            info = doc["recovery"]
            found.append(Orphan(path, Path(info["document_path"]) if info.get("document_path") else None,
                                float(info["saved_at"]), str(doc.get("name", "untitled")), fd))
        except (OSError, ValueError, KeyError, TypeError):
            os.close(fd)
    return sorted(found, key=lambda o: -o.saved_at)


# ---------------------------------------------------------------------- backups
def backup_paths(path: str | os.PathLike, count: int = BACKUPS) -> list[Path]:
    """``<stem>.backup-1<suffix>`` (newest) to ``.backup-<count>`` beside ``path``."""
    path = Path(path)
    return [path.with_name(f"{path.stem}.backup-{k}{path.suffix}") for k in range(1, count + 1)]


def save_with_backups(project: Project, path: str | os.PathLike, backups: int = BACKUPS) -> Path:
    """Save ``project`` to ``path`` atomically, first keeping the file already
    there as backup 1 (backup k becomes k + 1; the oldest beyond ``backups``
    goes). An unchanged file makes no new backup. The new file is written in
    full first, then the backups rotate, then it is renamed over ``path``:
    every step is a rename or a new file, so a crash at any point leaves the
    previous save whole (at ``path``, or at backup 1), and a failed write (a
    full disk) changes nothing. One-line FlatweaveError on failure."""
    path = Path(path)
    data = json_bytes(project_to_dict(project), path)
    try:
        old = path.read_bytes() if backups > 0 and path.is_file() else None
    except OSError:
        old = None

    def keep_backup():  # the new file is on disk by now: a failed save rotates nothing
        chain = backup_paths(path, backups)
        try:
            for newer, older in zip(chain[-2::-1], chain[:0:-1]):
                if newer.exists():
                    os.replace(newer, older)
            tmp = chain[0].with_name(f".{chain[0].name}.tmp")
            try:
                os.link(path, tmp)  # the old inode: the save replaces path, not it
            except OSError:
                shutil.copy2(path, tmp)
            os.replace(tmp, chain[0])
        except OSError as exc:
            raise FlatweaveError(f"cannot keep a backup of {path}: {exc.strerror or exc}") from None

    atomic_write_bytes(path, data, keep_backup if old is not None and old != data else None)
    return path
