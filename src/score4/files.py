"""Writing files so that nothing already written is lost or half-written."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from .errors import Score4Error


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike):
    """Yield a temporary path beside ``path``; rename it over ``path`` only if the block succeeds.

    A failure (disk full, permissions, an exception in the block) leaves any existing ``path``
    untouched and removes the temporary file; ``OSError`` becomes a :class:`Score4Error` naming
    the file.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent if str(path.parent) else ".", prefix=f".{path.name}.", suffix=".partial")
    os.close(fd)
    tmp = Path(tmp)
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as err:
        tmp.unlink(missing_ok=True)
        raise Score4Error(f"cannot write {path}: {err}") from err
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
