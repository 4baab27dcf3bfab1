"""Work the HTML writer repeats on every page, done once per build; the pages are the same.

- The navigation column.  pydata-sphinx-theme builds the column once for the pages of one
  section and folder, and for each further page moves the "current page" marks to that
  page's entry and serializes the whole column again (``str(soup)``): on an API page the
  column lists every module and every object (50 kB), and serializing it 240 times took
  2.3 of the build's ~27 CPU-s.  Moving the marks changes only the top-level entries that
  hold the previous page and the new one (and the opening tags above them), so this step
  keeps each top-level entry's text and serializes again only those two.  Where the
  theme lacks the internals of its 0.24 release (``_patch_cached_sidebar``,
  ``_sidebar_cache``, ``_move_current_markers``) it is left as it is, and the first pages
  of each column are compared with the theme's own text (a difference: the column is
  serialized whole from then on).
- The search index.  Each page's words are stemmed one by one (33 000 calls, 0.7 CPU-s);
  a word's stem depends on the word alone, so each distinct word is stemmed once.
"""

from __future__ import annotations

import functools

from bs4 import Tag

try:
    from pydata_sphinx_theme import toctree as _theme_toctree
except ImportError:  # another theme
    _theme_toctree = None

#: id(soup) of each of the theme's cached columns -> {"texts": {id(top-level entry): (entry,
#: its text)}, "checks": pages still to compare with the theme's own text, "links": its
#: links by address, "current": the current page's links}
_STATE: dict[int, dict] = {}
#: pages of each column whose text is compared with the theme's own
_CHECKS = 3


def _opening(tag: Tag) -> str:
    """``tag``'s opening tag as bs4 writes it."""
    empty = Tag(name=tag.name, attrs=dict(tag.attrs))
    return str(empty)[: -len(f"</{tag.name}>")]


def _top_entries(soup, anchors) -> set[int]:
    """ids of the top-level entries (children of the column's root elements) holding
    ``anchors``."""
    tops = set()
    for anchor in anchors:
        node = anchor
        while node.parent is not None and node.parent.parent is not soup:
            node = node.parent
        if node.parent is not None:
            tops.add(id(node))
    return tops


def _serialize(soup, texts: dict, stale: set[int]) -> str:
    """``str(soup)``, with the kept text of each top-level entry not in ``stale``."""
    parts = []
    for root in soup.contents:
        if not isinstance(root, Tag):
            parts.append(root.output_ready())
            continue
        parts.append(_opening(root))
        for entry in root.contents:
            if id(entry) in stale or id(entry) not in texts:
                text = str(entry) if isinstance(entry, Tag) else entry.output_ready()
                texts[id(entry)] = (entry, text)
            parts.append(texts[id(entry)][1])
        parts.append(f"</{root.name}>")
    return "".join(parts)


def _patch_cached_sidebar(app, cache_key, pagename, show_nav_level):
    """The theme's ``_patch_cached_sidebar``: the cached column with this page's marks,
    serialized again only where the marks moved."""
    cached = _theme_toctree._sidebar_cache(app).get(cache_key)
    if cached is None:
        return None
    cached_pagename, cached_soup = cached
    old_href = app.builder.get_relative_uri(pagename, cached_pagename)
    new_href = app.builder.get_relative_uri(cached_pagename, pagename)
    state = _STATE.get(id(cached_soup))
    if state is None:
        # the column's links by the address each shows when not the current page's (the
        # current page's own shows "#"; it gets ``old_href`` back when the marks move)
        links: dict[str, list] = {}
        current = cached_soup.find_all("a", href="#")
        current_ids = {id(anchor) for anchor in current}
        for anchor in cached_soup.find_all("a"):
            href = old_href if id(anchor) in current_ids else anchor.get("href")
            links.setdefault(href, []).append(anchor)
        state = {"texts": {}, "checks": _CHECKS, "links": links, "current": current}
        _STATE[id(cached_soup)] = state
    patched = _theme_toctree._move_current_markers(
        cached_soup, old_href=old_href, new_href=new_href, show_nav_level=show_nav_level
    )
    if not patched:
        return None
    cached[0] = pagename
    if state["texts"] is None:  # the kept texts gave another column once: not used
        return str(cached_soup)
    stale = set()
    if old_href != new_href:
        now = state["links"].get(new_href, [])
        stale = _top_entries(cached_soup, [*state["current"], *now])
        state["current"] = now
    text = _serialize(cached_soup, state["texts"], stale)
    if state["checks"]:
        # the first pages of each column are compared with the theme's own text: should a
        # theme release move marks elsewhere, the column is serialized whole again
        state["checks"] -= 1
        if text != str(cached_soup):
            state["texts"] = None
            return str(cached_soup)
    return text


def _stem_once(app, pagename, templatename, context, doctree):
    indexer = getattr(app.builder, "indexer", None)
    lang = getattr(indexer, "lang", None)
    if lang is not None and not isinstance(lang.stem, functools._lru_cache_wrapper):
        lang.stem = functools.cache(lang.stem)


def setup(app):
    theme = _theme_toctree
    if theme is not None and all(
        hasattr(theme, name)
        for name in ("_patch_cached_sidebar", "_sidebar_cache", "_move_current_markers")
    ):
        theme._patch_cached_sidebar = _patch_cached_sidebar
    app.connect("html-page-context", _stem_once)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
