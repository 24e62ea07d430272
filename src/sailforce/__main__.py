"""``python -m sailforce``: the ``sail`` command line, for environments without the console script on PATH."""

from .cli import main

if __name__ == "__main__":
    main()
