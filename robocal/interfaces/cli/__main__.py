"""``python -m robocal.interfaces.cli``: the command line."""
from . import main

main()
