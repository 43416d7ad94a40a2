"""Where a package's data files (URDF, configs, layouts, launch files, rviz configs) are.

ROS installs them to ``<prefix>/share/<package>`` and indexes the prefix in the ament resource
index (``AMENT_PREFIX_PATH``): that is where a ``colcon build`` — copying or
``--symlink-install`` — and a Docker image put them, and what :func:`package_share` looks up
first. The pip path (``setup.sh``: editable installs into a virtual environment) installs no
data files; there the package's source tree (``<package>/package.xml`` beside the module
``<package>/<package>/``) holds them, and a non-editable pip install with data files leaves them
in ``<sys.prefix>/share/<package>``.

Data is never looked up relative to a module's ``__file__``: in a plain colcon build the module
is a copy under ``lib/python3.X/site-packages`` with no data beside it.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path


def ament_share(package: str) -> Path | None:
    """``<prefix>/share/<package>`` of the first prefix on ``AMENT_PREFIX_PATH`` whose ament
    resource index lists ``package`` (what ``ament_index_python`` answers), or None."""
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if not prefix:
            continue
        marker = Path(prefix) / "share" / "ament_index" / "resource_index" / "packages" / package
        share = Path(prefix) / "share" / package
        if marker.is_file() and share.is_dir():
            return share
    return None


def source_tree(package: str) -> Path | None:
    """The package's source directory (``package.xml`` beside the module directory) when the
    module is imported from a source checkout or an editable install, or None."""
    try:
        spec = importlib.util.find_spec(package)
    except (ImportError, ValueError):
        return None
    if spec is None:
        return None
    modules = [Path(p).resolve() for p in (spec.submodule_search_locations or [])]
    # With the repository root on sys.path, the outer directory itself can be found as a
    # namespace package: then it is the source tree.
    for candidate in (d for m in modules for d in (m.parent, m)):
        if (candidate / "package.xml").is_file() and (candidate / package).is_dir():
            return candidate
    return None


def package_share(package: str) -> Path:
    """The directory holding ``package``'s data files: the ament index's share directory, else
    the source tree, else ``<sys.prefix>/share/<package>``.

    Raises:
        FileNotFoundError: none of them exists; the message lists where it looked.
    """
    found = ament_share(package) or source_tree(package)
    if found is not None:
        return found
    fallback = Path(sys.prefix) / "share" / package
    if (fallback / "package.xml").is_file():
        return fallback
    prefixes = os.environ.get("AMENT_PREFIX_PATH", "") or "(unset)"
    raise FileNotFoundError(
        f"{package}: data files not found: not in the ament index (AMENT_PREFIX_PATH={prefixes}),"
        f" no source tree beside an importable module {package!r}, no {fallback}; build and "
        "source the workspace (colcon build; source install/setup.bash) or run ./setup.sh")


def share_file(package: str, relative: str | Path) -> Path:
    """``package_share(package) / relative``, which must exist.

    Raises:
        FileNotFoundError: the file is missing (the message names the package and the path).
    """
    path = package_share(package) / relative
    if not path.exists():
        raise FileNotFoundError(f"{package}: {relative} is not in its data files ({path})")
    return path
