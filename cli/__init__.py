"""The ``nightlights`` command-line interface: thin click commands over the stage functions."""
