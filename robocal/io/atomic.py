"""Write files so that a reader never sees half of them.

A crash, a full disk, Ctrl-C or SIGTERM while writing must not leave a truncated model or
command file behind, and must not destroy the previous version.  The data therefore
go to a temporary file in the target's own directory (so that the final rename stays on
one file system and is atomic), are flushed to disk, and only then replace the target.

An interruption (``KeyboardInterrupt``, or the ``SystemExit`` the command line raises on
SIGTERM) that stops a write removes the temporary file and is re-raised with the attribute
``unwritten_file``: the target it left as it was, for the one line the command line prints.

What an output path may be is judged here, for every command, before any work
(:func:`check_outputs`) and again as it is written: a name ending in ``/`` names a folder,
not a file, and is refused (``--out newdir/`` used to write a file ``newdir``); so are a
folder, a disk (a block device) and a socket.  A device such as ``/dev/null`` or a pipe
(``--out /dev/stdout`` in a pipeline) is written through, never renamed over; a named pipe
no program reads is refused at once, where opening it would wait for a reader for ever.
The descriptor the check opens on a pipe is kept for the write: closing it would tell the
reader the output had ended.

A command writes several files (a measurement file and its truth, a dataset's four files, a
fleet's folders), and one that fails half-way must not leave the first ones behind:
:func:`outputs_together` makes the files and folders written in its block one unit.  Each
file still takes its final name as soon as it is written (the command may read it back), but
on a failure or an interruption the files it created are removed, the files it replaced get
their earlier content back, and the folders it created (:func:`make_directory`) go with
everything in them.  The command line runs every verb in one.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import os
import secrets
import shutil
import stat
from collections.abc import Iterable
from pathlib import Path

from robocal.errors import InputError

# Large contents are written in slices, so that an interruption is acted on within one slice
# rather than after the whole file.
_SLICE = 1 << 22


def write_text_atomic(path: str | os.PathLike, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` atomically; see :func:`write_bytes_atomic`.

    The text is encoded as given: no newline translation happens, so ``"\\n"`` stays
    ``"\\n"`` on every platform.
    """
    return write_bytes_atomic(path, text.encode(encoding))


def write_bytes_atomic(path: str | os.PathLike, data: bytes | Iterable[bytes]) -> Path:
    """Write ``data`` (bytes, or an iterable of byte chunks) to ``path`` atomically and
    return the path.

    Either the complete new content is at ``path`` afterwards, or (on any failure or
    interruption) an existing file there is untouched and no temporary file is left behind.
    An existing target keeps its permission bits.

    Raises:
        InputError: the directory does not exist, ``path`` is a directory, or the
            directory is not writable.
    """
    target = _output_path(path)
    directory = target.parent
    _check_writable_target(target, directory)
    if _is_device(target):
        return _write_through(target, data)
    temporary = directory / f".{target.name}.{secrets.token_hex(8)}.tmp"
    descriptor = None
    try:
        # O_EXCL: never write through a file (or symlink) someone else created under this
        # name; mode 0o666 lets the umask decide, as for any ordinary new file.
        descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
        with os.fdopen(descriptor, "wb") as stream:
            for chunk in _slices(data):
                stream.write(chunk)
            stream.flush()
            os.fsync(stream.fileno())
        if target.exists():
            os.chmod(temporary, stat.S_IMODE(target.stat().st_mode))
        promote(temporary, target)
    except BaseException as error:
        if descriptor is None and isinstance(error, OSError):  # the temporary file was never created
            raise _cannot_create(target, directory, error) from error
        # The rename is the last step: a temporary file that is gone was renamed (or never made).
        replaced = descriptor is not None and not temporary.exists()
        temporary.unlink(missing_ok=True)
        if not isinstance(error, Exception) and not replaced and not hasattr(error, "unwritten_file"):
            error.unwritten_file = target  # interrupted: say which file was left as it was
        if isinstance(error, OSError):
            # A write the system stopped (disk full, a file-size limit): its error names no
            # file, so say which output, and that nothing of it was written.
            raise InputError(f"cannot write {target}: {error.strerror or error}; it is left as it was: free space, "
                             "or choose another --out") from None
        raise
    _sync_directory(directory)
    return target


# The outputs of the running command (outputs_together), None outside one.
_OUTPUTS = contextvars.ContextVar("robocal_outputs", default=None)


class _Outputs:
    """What a block of :func:`outputs_together` wrote: files created, (file, backup of its
    earlier content) replaced, folders created."""

    def __init__(self):
        self.created, self.replaced, self.directories = [], [], []

    def undo(self):
        for path in reversed(self.created):
            path.unlink(missing_ok=True)
        for target, backup in reversed(self.replaced):
            with contextlib.suppress(OSError):
                os.replace(backup, target)
        for folder in reversed(self.directories):
            shutil.rmtree(folder, ignore_errors=True)

    def keep(self):
        for _, backup in self.replaced:
            backup.unlink(missing_ok=True)


@contextlib.contextmanager
def outputs_together(keep_on=()):
    """Make the files and folders written in the block one unit (module notes): on an
    exception (or interruption) not among ``keep_on`` every one is undone.  Nested blocks
    belong to the outermost."""
    if _OUTPUTS.get() is not None:
        yield
        return
    outputs = _Outputs()
    token = _OUTPUTS.set(outputs)
    try:
        yield
    except BaseException as error:
        if isinstance(error, keep_on):
            outputs.keep()
        else:
            outputs.undo()
        raise
    else:
        outputs.keep()
    finally:
        _OUTPUTS.reset(token)
        _close_held_pipes()


def promote(source: str | os.PathLike, target: str | os.PathLike) -> None:
    """Rename the finished file ``source`` to ``target`` (same folder), recorded by the
    running :func:`outputs_together`: a file it replaces is kept aside (a hard link, else a
    copy) until the block ends, to be put back if the block fails."""
    source, target = Path(source), Path(target)
    outputs = _OUTPUTS.get()
    if outputs is None:
        os.replace(source, target)
        return
    backup = None
    if target.exists() and target not in outputs.created:  # one it created is removed, not restored
        backup = target.parent / f".{target.name}.{secrets.token_hex(8)}.bak"
        try:
            os.link(target, backup, follow_symlinks=False)  # a symbolic link is put back as one
        except OSError:  # a file system without hard links
            shutil.copy2(target, backup, follow_symlinks=False)
    try:
        os.replace(source, target)
    except BaseException:
        if backup is not None:
            backup.unlink(missing_ok=True)
        raise
    if backup is None:
        if target not in outputs.created:
            outputs.created.append(target)
    else:
        outputs.replaced.append((target, backup))


def make_directory(path: str | os.PathLike) -> Path:
    """Create the folder ``path`` and its missing parents unless it is there; the folders
    this creates inside :func:`outputs_together` are removed, with their contents, if the
    block fails."""
    path = Path(path)
    topmost = None
    for folder in (path, *path.parents):
        if folder.exists():
            break
        topmost = folder
    if topmost is None:
        return path
    path.mkdir(parents=True, exist_ok=True)
    outputs = _OUTPUTS.get()
    if outputs is not None:
        outputs.directories.append(topmost)
    return path


def _is_device(target: Path) -> bool:
    """True when ``target`` exists and is not a regular file (``/dev/null``, ``/dev/stdout``,
    a terminal, a pipe): renaming a file over it would replace the device itself (as root,
    ``/dev/null`` would become a regular file), so it is written through instead."""
    try:
        mode = target.stat().st_mode
    except OSError:
        return False
    return not stat.S_ISREG(mode) and not stat.S_ISDIR(mode)


# The write ends of the pipes check_outputs found a reader on, by (device, inode): kept open
# for the write, since closing one would end the reader's input before anything was written.
_PIPES = {}


def _held_pipe(target: Path):
    """The write end of the pipe ``target`` (None when it is no pipe), opened without waiting:
    a named pipe that no program reads is refused (opening it to write would wait for one)."""
    try:
        status = target.stat()
    except OSError:
        return None
    if not stat.S_ISFIFO(status.st_mode):
        return None
    key = (status.st_dev, status.st_ino)
    if key not in _PIPES:
        try:
            _PIPES[key] = os.open(target, os.O_WRONLY | os.O_NONBLOCK)
        except OSError as error:
            if error.errno == errno.ENXIO:
                raise InputError(f"{target} is a named pipe (FIFO) that no program reads: writing it would wait "
                                 "for ever; start its reader first, or choose a regular file for --out") from None
            raise InputError(f"cannot write {target}: {error.strerror or error}; choose another --out") from None
    return key


def _close_held_pipes():
    """Close the pipes checked but not written (the command failed first): their readers
    see the end of an empty output."""
    while _PIPES:
        with contextlib.suppress(OSError):
            os.close(_PIPES.popitem()[1])


def _write_through(target: Path, data) -> Path:
    """Write ``data`` into the existing device or pipe ``target`` as a stream (no atomicity
    exists for one); a device that refuses the bytes (``/dev/full``), or a pipe whose reader
    stops, is an InputError.  The device is opened without waiting (a serial line waits for
    its carrier), then written in the ordinary blocking way."""
    try:
        key = _held_pipe(target)
        descriptor = _PIPES.pop(key) if key is not None else os.open(target, os.O_WRONLY | os.O_NONBLOCK)
        os.set_blocking(descriptor, True)
        with os.fdopen(descriptor, "wb") as stream:
            for chunk in _slices(data):
                stream.write(chunk)
    except OSError as error:
        raise InputError(f"cannot write {target}: {error.strerror or error}; choose another --out") from None
    return target


def _slices(data):
    """The chunks to write: slices of a bytes-like object, or the items of an iterable."""
    if isinstance(data, (bytes, bytearray, memoryview)):
        view = memoryview(data)
        return (view[start:start + _SLICE] for start in range(0, max(len(view), 1), _SLICE))
    return data


def _cannot_create(target: Path, directory: Path, error: OSError) -> InputError:
    if isinstance(error, PermissionError):
        return InputError(f"cannot write {target}: no permission to create files in {directory}")
    return InputError(f"cannot write {target}: {error.strerror or error}; choose another --out")


def check_outputs(outputs, inputs=()) -> None:
    """Before a command computes anything: every output (paths, None skipped) can be written
    (its folder exists, it is not a folder), no two outputs are the same file, and no output
    is one of the ``inputs`` (a model written over the measurements it was fitted to).
    Raises InputError naming the path."""
    outputs = [_output_path(o) for o in outputs if o is not None]
    for target in outputs:
        _check_writable_target(target, target.parent)
        _held_pipe(target)  # a pipe without a reader is refused before any work
    for k, target in enumerate(outputs):
        if _is_device(target):  # /dev/null for two outputs, or an input read from a terminal
            continue
        for other in outputs[k + 1:]:
            if _same_file(target, other):
                raise InputError(f"{target} is given for two outputs: choose a different name for each")
        for source in (Path(i) for i in inputs if i is not None):
            if _same_file(target, source):
                raise InputError(f"{target} is also an input of this command: writing it would destroy it; "
                                 "choose another --out")


def _same_file(a: Path, b: Path) -> bool:
    if a.exists() and b.exists():
        return os.path.samefile(a, b)
    return a.resolve() == b.resolve()


def _output_path(path: str | os.PathLike) -> Path:
    """``path`` as a Path, refused when its text names a folder by its form (``newdir/``,
    ``newdir/.``): a Path drops the ending and would write a file ``newdir``."""
    text = os.fspath(path)
    if isinstance(text, str) and os.path.basename(text) in ("", ".") and not Path(text).is_dir():
        raise InputError(f"{text} names a folder, not a file: give a file name, e.g. "
                         f"{os.path.join(os.path.normpath(text), 'NAME')}")
    return Path(text)


def _check_writable_target(target: Path, directory: Path) -> None:
    """Fail with a one-line explanation before anything is created."""
    if not directory.is_dir():
        if directory.exists():
            raise InputError(f"{directory} is a file, not a directory: choose another --out")
        raise InputError(f"directory {directory} does not exist: create it or choose another --out")
    if target.is_dir():
        raise InputError(f"{target} is a directory: give a file name, e.g. {target / 'out.csv'}")
    try:
        mode = target.stat().st_mode
    except OSError:
        return
    if stat.S_ISBLK(mode):
        raise InputError(f"{target} is a disk (a block device): robocal writes files, never over a disk; "
                         "choose another --out")
    if stat.S_ISSOCK(mode):
        raise InputError(f"{target} is a socket, not a file: choose another --out")


def _sync_directory(directory: Path) -> None:
    """Make the rename itself durable; without this a power cut may undo it on POSIX."""
    if os.name != "posix":
        return
    descriptor = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)
