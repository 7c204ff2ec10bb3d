"""How the QIF readers (engine.io.qif_plan, qif_characteristics, qif_dimensions) name what
they read: an element's local name, the ids a list element holds, a QIF kind in words."""

from __future__ import annotations

import re


def local_name(e) -> str:
    """An element's name without its namespace."""
    return e.tag.split("}", 1)[1] if e.tag.startswith("{") else e.tag


def ids_of(e, tag: str) -> list[str]:
    """The ``Id`` texts under ``e``'s child ``tag``."""
    return [i.text.strip() for i in e.iterfind(f"{{*}}{tag}/{{*}}Id") if i.text]


def words(camel: str) -> str:
    """'DistanceBetween' -> 'distance between'."""
    return re.sub(r"(?<!^)(?=[A-Z])", " ", camel).lower()
