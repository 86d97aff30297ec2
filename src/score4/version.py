"""The installed score4's version (``score4.__version__``), read once when first asked: the
package's modules ask here, not the package root, which sits above them all."""

from __future__ import annotations

import functools


@functools.cache
def package_version() -> str:
    """The version of the installed score4 distribution ("0.0.0+unknown" from a bare source
    tree)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("score4")
    except PackageNotFoundError:  # running from a source tree without installation
        return "0.0.0+unknown"
