"""``nightlights demo``."""

commands: list = []
