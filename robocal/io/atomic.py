"""Write files so that a reader never sees half of them.

A crash, a full disk or Ctrl-C while writing must not leave a truncated model or
command file behind, and must not destroy the previous version.  The data therefore
go to a temporary file in the target's own directory (so that the final rename stays on
one file system and is atomic), are flushed to disk, and only then replace the target.
"""

from __future__ import annotations

import os
import secrets
import stat
from pathlib import Path

from robocal.errors import InputError


def write_text_atomic(path: str | os.PathLike, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically; see :func:`write_bytes_atomic`.

    The text is encoded as given: no newline translation happens, so ``"\\n"`` stays
    ``"\\n"`` on every platform.
    """
    return write_bytes_atomic(path, text.encode(encoding))


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically and return the path.

    Either the complete new content is at ``path`` afterwards, or (on any failure) an
    existing file there is untouched and no temporary file is left behind.  An existing
    target keeps its permission bits.

    Raises:
        InputError: the directory does not exist, ``path`` is a directory, or the
            directory is not writable.
    """
    target = Path(path)
    directory = target.parent
    _check_writable_target(target, directory)
    temporary = directory / f".{target.name}.{secrets.token_hex(8)}.tmp"
    try:
        # O_EXCL: never write through a file (or symlink) someone else created under this
        # name; mode 0o666 lets the umask decide, as for any ordinary new file.
        descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
    except PermissionError as error:
        raise InputError(f"cannot write {target}: no permission to create files in {directory}") from error
    except OSError as error:
        raise InputError(f"cannot write {target}: {error.strerror or error}; choose another --out") from error
    try:
        with os.fdopen(descriptor, "wb") as stream:
            stream.write(data)
            stream.flush()
            os.fsync(stream.fileno())
        if target.exists():
            os.chmod(temporary, stat.S_IMODE(target.stat().st_mode))
        os.replace(temporary, target)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    _sync_directory(directory)
    return target


def _check_writable_target(target: Path, directory: Path) -> None:
    """Fail with a one-line explanation before anything is created."""
    if not directory.is_dir():
        raise InputError(f"directory {directory} does not exist: create it or choose another --out")
    if target.is_dir():
        raise InputError(f"{target} is a directory: give a file name, e.g. {target / 'out.csv'}")


def _sync_directory(directory: Path) -> None:
    """Make the rename itself durable; without this a power cut may undo it on POSIX."""
    if os.name != "posix":
        return
    descriptor = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)
