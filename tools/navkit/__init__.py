"""navkit: firmware-in-the-loop co-design kit for laptop + microcontroller robots.

Subpackages and modules are imported lazily by the CLI (`navkit.cli:main`).
"""

__all__ = ["__version__"]

__version__ = "0.1.0"
