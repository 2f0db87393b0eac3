"""The ``nightlights`` command-line interface: thin click commands over the stage functions.

The folder ``cli/`` is installed as the package ``nightlights_cli`` (``import nightlights_cli``;
the console script ``nightlights`` runs :func:`nightlights_cli.main.main`); its modules import
each other relatively.
"""
