"""``python -m robocal``: the command line, as the ``robocal`` script runs it."""
from .entry import main

main()
