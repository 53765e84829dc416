"""``python -m robocal``: the command line, as the ``robocal`` script runs it."""
from .interfaces.cli import main

main()
