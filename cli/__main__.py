"""``python -m nightlights_cli``: the ``nightlights`` command without its console script."""

from .main import main

if __name__ == "__main__":
    main()
