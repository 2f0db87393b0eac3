"""``nightlights streets sample`` and ``streets fit``."""

commands: list = []
