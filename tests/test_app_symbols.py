"""The app draws every characteristic type's symbol from the certificate's strokes
(reports.symbols): fonts lack most of them, and the app drew only four (perpendicularity,
runout, cylindricity … showed a blank icon)."""

import pytest

from engine.gdt.plan import CHARACTERISTICS


def _inked(pm) -> int:
    img = pm.toImage()
    return sum(img.pixelColor(x, y).alpha() > 0
               for x in range(img.width()) for y in range(img.height()))


@pytest.mark.parametrize("kind", CHARACTERISTICS)
def test_every_type_has_an_icon(qapp, kind):
    from qa_app.desktop.widgets.characteristic_table import symbol_icon

    assert _inked(symbol_icon(kind, 24)) >= 10


def test_a_width_has_no_sign_and_a_sphere_more_than_a_cylinder(qapp):
    from qa_app.desktop.widgets.characteristic_table import symbol_icon

    assert _inked(symbol_icon("size", 24, feature="width")) == 0
    assert _inked(symbol_icon("size", 24, feature="sphere")) > 0


def test_two_types_are_not_drawn_alike(qapp):
    """Each symbol is its own drawing: no two types' icons are the same picture (coaxiality
    and concentricity share theirs, as on a drawing)."""
    from qa_app.desktop.widgets.characteristic_table import symbol_icon

    pictures = {}
    for kind in CHARACTERISTICS:
        img = symbol_icon(kind, 24).toImage()
        key = bytes(img.constBits())
        pictures.setdefault(key, []).append(kind)
    assert sorted(map(sorted, pictures.values()), key=len)[-1] in (
        ["coaxiality", "concentricity"], [sorted(CHARACTERISTICS)[0]])
    assert all(len(v) == 1 for v in pictures.values() if v != ["coaxiality", "concentricity"])
