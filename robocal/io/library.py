"""The built-in robot library and the one place that turns a ROBOT argument into a chain.

A ROBOT is a built-in name (``robocal robots`` lists them), a robot TOML file, or a URDF file
(with root and tip links chosen by option).
"""
from functools import cache
from importlib import resources
from pathlib import Path

from ..errors import InputError
from ..kinematics import Chain
from .robot_file import read_robot

_PACKAGE = "robocal.io"
_FOLDER = "robots"


def _files():
    return {p.name[: -len(".toml")]: p for p in resources.files(_PACKAGE).joinpath(_FOLDER).iterdir()
            if p.name.endswith(".toml")}


def builtin_names():
    """Names of the built-in robots, sorted."""
    return sorted(_files())


def _normalise(name):
    return "".join(ch for ch in name.lower() if ch.isalnum())


@cache
def _load_builtin(key):
    with resources.as_file(_files()[key]) as path:
        return read_robot(path)


def builtin(name) -> Chain:
    """A built-in robot by name (case and punctuation do not matter: 'KR150-2' = 'kr1502')."""
    wanted = _normalise(name)
    for key in _files():
        if _normalise(key) == wanted:
            return _load_builtin(key)
    raise InputError(
        f"no built-in robot named {name!r}; built-in robots: {', '.join(builtin_names())} "
        "(or give the path of a robot .toml or .urdf file)"
    )


def builtin_description(name):
    """The one-line description stored in a built-in robot file."""
    from .robot_file import tomllib  # the same parser the reader uses

    key = next(k for k in _files() if _normalise(k) == _normalise(name))
    return tomllib.loads(_files()[key].read_text(encoding="utf-8")).get("description", "")


def load_robot(spec, *, root=None, tip=None) -> Chain:
    """A chain from a built-in name, a robot TOML path or a URDF path."""
    if isinstance(spec, Chain):
        return spec
    text = str(spec)
    if not text.strip():
        raise InputError("the robot is empty: give a built-in name (robocal robots), a robot .toml or a .urdf file")
    path = Path(text)
    suffix = path.suffix.lower()
    if suffix != ".urdf" and (root is not None or tip is not None):
        raise InputError(f"--root and --tip choose links of a URDF file; {text} is not one: leave them out")
    if suffix == ".urdf":
        from .urdf import read_urdf  # XML parsing only when a URDF is asked for

        return read_urdf(path, root=root, tip=tip)
    if suffix == ".toml":
        return read_robot(path)
    if path.exists():
        if path.is_file():  # robocal's other files are named (a model, a truth file, a report...)
            from .file_kinds import check
            from .reading import read_text

            check(path, "robot", text=read_text(path, "robot file", "settings"))
        raise InputError(f"{text}: a robot file must end in .toml or .urdf")
    return builtin(text)
