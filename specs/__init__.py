"""clomp.specs — what is checked: scenario files, PCTL property files, protocol notes.

Data only; located at run time through this package so that an installed clomp finds them.
"""

from pathlib import Path

__all__ = ["SPECS_DIR"]

SPECS_DIR = Path(__file__).resolve().parent
