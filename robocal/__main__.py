"""``python -m robocal``: the command line, where the ``robocal`` script is not on PATH."""
from robocal.interfaces.cli import main

main()
