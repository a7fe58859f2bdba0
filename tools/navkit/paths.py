"""Where things are: the repository, the spec, the build folder."""

import os
from pathlib import Path

__all__ = ["repo_root", "spec_path", "build_dir"]


def repo_root() -> Path:
    """The repository root (the folder holding `protocol/navkit.toml`)."""
    return Path(__file__).resolve().parents[2]


def spec_path() -> Path:
    """The protocol spec, `protocol/navkit.toml`."""
    return repo_root() / "protocol" / "navkit.toml"


def build_dir() -> Path:
    """The CMake build folder: `$NAVKIT_BUILD_DIR`, else `<repo>/build`."""
    env = os.environ.get("NAVKIT_BUILD_DIR")
    return Path(env).resolve() if env else repo_root() / "build"
