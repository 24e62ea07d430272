"""``python -m sailforce.cli``."""

from . import main

main()
