"""``python -m lamech``: the ``lamech`` command."""

import sys

from .cli import main

sys.exit(main())
