"""The docs site (mkdocs.yml, `make docs`): every page of docs/ is in its navigation once."""

from __future__ import annotations

from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


def _nav_pages(node) -> list[str]:
    if isinstance(node, str):
        return [node]
    if isinstance(node, dict):
        return [p for value in node.values() for p in _nav_pages(value)]
    return [p for item in node for p in _nav_pages(item)]


def test_every_page_is_in_the_site_navigation_once() -> None:
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    pages = _nav_pages(config["nav"])
    assert sorted(pages) == sorted(set(pages)), "a page is listed twice"
    assert set(pages) == {p.name for p in (ROOT / "docs").glob("*.md")}


def test_the_api_reference_names_the_public_face() -> None:
    """docs/reference.md renders every public name of score4 (score4.__all__)."""
    import score4

    text = (ROOT / "docs" / "reference.md").read_text()
    for name in set(score4.__all__) - {"__version__", "api"}:
        assert f".{name}\n" in text, name
