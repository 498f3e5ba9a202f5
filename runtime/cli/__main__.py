"""``python -m clomp.runtime.cli``: the ``clomp`` command line."""

import sys

from clomp.runtime.cli import main

sys.exit(main())
