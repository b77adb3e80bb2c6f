"""``python -m lamech``: the ``lamech`` command."""

import sys

try:
    from .cli import main
except KeyboardInterrupt:  # Ctrl-C while Python is still loading lamech (a busy machine)
    print("lamech: interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
