"""``python -m runtime.cli``: the ``clomp`` command line."""

import sys

from runtime.cli import main

sys.exit(main())
