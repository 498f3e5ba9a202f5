"""pytest at the repository's root: the optional extras' modules are not collected without them.

``clomp.runtime.gym`` needs ``gymnasium`` (``clomp[gym]``, in the test extra): without it, its
doctests (and docs/gym.md's) are skipped rather than failing to import.
"""

import importlib.util

collect_ignore_glob = [] if importlib.util.find_spec("gymnasium") else ["clomp/runtime/gym/*.py", "runtime/gym/*.py", "docs/gym.md"]
