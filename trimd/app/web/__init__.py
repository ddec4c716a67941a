"""``trimd serve``'s HTTP side: the JSON API and the page for people (:mod:`.routes`),
the page's files in ``static/`` (package data; no CDN: the vehicle is offline)."""

from trimd.app.web.routes import API_PATHS, make_app

__all__ = ["API_PATHS", "make_app"]
