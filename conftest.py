"""Collection for the whole repository: the old import paths kept for one release are not collected.

Each of them warns when imported (:mod:`sailforce._moved`), and the suite
turns that warning into an error, so that no test uses an old path by accident;
``tests/test_api.py`` imports them on purpose.
"""

from pathlib import Path

SRC = Path(__file__).parent / "src" / "sailforce"

collect_ignore = [str(path) for path in SRC.rglob("*.py") if "from .._moved import moved" in path.read_text()
                  or "from ._moved import moved" in path.read_text()]  # fmt: skip
