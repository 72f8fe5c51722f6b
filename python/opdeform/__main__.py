"""python -m opdeform: the opdeform command (opdeform.cli)."""

import sys

from .cli import main

sys.exit(main(prog="python -m opdeform"))
