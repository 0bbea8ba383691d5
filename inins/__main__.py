"""``python -m inins``: the same as the ``inins`` command."""

from inins.cli import main

if __name__ == "__main__":
    main()
