"""clomp.runtime — executing plans on robots: supervisor, devices, simulation, command line."""

__all__: list[str] = []
