"""MkDocs hooks of the score4 site (``hooks:`` in mkdocs.yml).

The docstrings use Sphinx roles (``:func:`plan_run```), which mkdocstrings' numpy style leaves
as text before the code span; the site shows the code span alone.
"""

from __future__ import annotations

import re
from typing import Any

_ROLE = re.compile(r":(?:func|class|meth|attr|mod|data|exc|obj):(<code>)~?")


def on_page_content(html: str, **_: Any) -> str:
    """The page's HTML without the role prefixes of code spans."""
    return _ROLE.sub(r"\1", html)
