"""``python -m clomp``: the ``clomp`` command line."""

from clomp.runtime.cli import main

raise SystemExit(main())
