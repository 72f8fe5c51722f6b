"""``python -m opdeform``: the command line of opdeform.cli."""

import sys

from .cli import main

sys.exit(main())
