"""pytest at the repository's root: the optional extras' modules are not collected without them.

``clomp.runtime.gym`` needs ``gymnasium`` (``clomp[gym]``, in the test extra): without it, its
doctests (and docs/gym.md's) are skipped rather than failing to import.
"""

import importlib.util

_without_gym = importlib.util.find_spec("gymnasium") is None
collect_ignore_glob = ["clomp/runtime/gym/*.py", "runtime/gym/*.py"] if _without_gym else []
collect_ignore = ["docs/gym.md"] if _without_gym else []
