"""clomp.planner — core knowledge (pymunk) and the Configurator."""

__all__: list[str] = []
