"""How the 3D view draws a characteristic on the part (what part_view.Highlight says): its faces
over the faded nominal, its datums' faces with their flags, its feature control frame as a
framed label at the feature; and which face lies under a pixel (the hover)."""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import QColor, QFont, QFontMetrics, QImage, QPainter, QPen

from .part_view import Highlight, PartFaces
from .widgets.characteristic_table import symbol_icon

ACTORS = ("qa-char-faces", "qa-char-edges", "qa-datum-faces", "qa-datum-flags", "qa-frame", "qa-anchor")
"""The actors a highlight adds (removed with it)."""
FACES_RGB = (1.0, 0.98, 0.90)
"""The characteristic's faces: near white, outlined (``EDGES_RGB``), so that no colour of the
deviation scale (its points') is read on them."""
EDGES_RGB = (0.85, 0.35, 0.0)
DATUM_RGB = (0.30, 0.45, 0.85)
DATUM_OPACITY = 0.35
"""The datums' faces, tinted: a datum plane may be the whole part's face."""
FADED_OPACITY = 0.3
"""The nominal's other faces, while a characteristic is shown."""
FRAME_OFFSET = (14, 14)
"""The frame's lower-left corner from the feature's centre, pixels (up and right)."""


def frame_image(h: Highlight, font: QFont | None = None) -> QImage:
    """The feature control frame as a drawing shows it: one cell per part of ``h.frame``
    (symbol and tolerance, then each datum), black lines on white; the characteristic's id
    above it, its other options (``h.note``) below; its symbol drawn where fonts lack it."""
    kind = h.type
    font = QFont(font or QFont())
    font.setPixelSize(15)
    small = QFont(font)
    small.setPixelSize(12)
    fm, sm = QFontMetrics(font), QFontMetrics(small)
    cells = h.frame.split(" | ")
    icon = cells[0][:1] != "⌀"  # every type's symbol is drawn (reports.symbols)
    if icon:
        cells[0] = cells[0].split(" ", 1)[-1]
    elif not fm.inFontUcs4(ord(cells[0][0])):  # a symbol no font has: its name instead
        cells[0] = kind.replace("_", " ") + cells[0][1:]
    pad, row = 7, fm.height() + 8
    widths = [fm.horizontalAdvance(t) + 2 * pad for t in cells]
    if icon:
        widths[0] += row - 6
    head = f"{h.id} · {kind.replace('_', ' ')}"
    w = max(sum(widths), sm.horizontalAdvance(head), sm.horizontalAdvance(h.note)) + 2
    top = sm.height() + 2
    hgt = top + row + (sm.height() + 2 if h.note else 0) + 2
    img = QImage(w, hgt, QImage.Format_RGB888)
    img.fill(QColor("white"))
    p = QPainter(img)
    p.setRenderHint(QPainter.Antialiasing)
    p.setFont(small)
    p.setPen(QColor("#333"))
    p.drawText(QRectF(1, 0, w, top), Qt.AlignLeft | Qt.AlignVCenter, head)
    if h.note:
        p.drawText(QRectF(1, top + row + 1, w, sm.height()), Qt.AlignLeft | Qt.AlignVCenter,
                   h.note)
    p.setFont(font)
    p.setPen(QPen(QColor("black"), 1.5))
    x = 1.0
    for k, (text, cw) in enumerate(zip(cells, widths)):
        cell = QRectF(x, top, cw, row)
        p.drawRect(cell)
        if k == 0 and icon:
            p.drawPixmap(QPointF(x + pad - 2, top + 3), symbol_icon(kind, row - 6))
            cell = cell.adjusted(row - 6, 0, 0, 0)
        p.drawText(cell, Qt.AlignCenter, text)
        x += cw
    p.end()
    return img


def _image_data(img: QImage):
    """A QImage as vtkImageData (RGB, rows from the bottom as VTK counts them)."""
    import pyvista as pv

    img = img.convertToFormat(QImage.Format_RGB888)
    w, h = img.width(), img.height()
    raw = np.frombuffer(img.constBits(), np.uint8, img.bytesPerLine() * h)
    rgb = raw.reshape(h, img.bytesPerLine())[:, :3 * w].reshape(h, w, 3)[::-1]
    data = pv.ImageData(dimensions=(w, h, 1))
    data.point_data["rgb"] = np.ascontiguousarray(rgb).reshape(-1, 3)
    return data


def _surface(faces: PartFaces, ids) -> object:
    import pyvista as pv

    return pv.PolyData.from_regular_faces(faces.points, faces.triangles[faces.triangles_of(ids)])


def _in_front(actor) -> None:
    """Draw the actor's triangles in front of the nominal's, which they lie on."""
    m = actor.GetMapper()
    m.SetResolveCoincidentTopologyToPolygonOffset()
    m.SetRelativeCoincidentTopologyPolygonOffsetParameters(-2.0, -2.0)


def draw(plotter, faces: PartFaces | None, h: Highlight | None) -> None:
    """Show ``h`` (None: nothing, the nominal as it was) without rendering."""
    from vtkmodules.vtkRenderingCore import vtkActor2D, vtkCoordinate, vtkImageMapper

    for name in ACTORS:
        plotter.remove_actor(name, render=False)
    nominal = plotter.renderer.actors.get("qa-nominal")
    if nominal is not None and hasattr(nominal, "GetProperty"):
        nominal.GetProperty().SetOpacity(1.0 if h is None else FADED_OPACITY)
    if h is None:
        return
    if faces is not None and h.faces:
        surf = _surface(faces, h.faces)
        _in_front(plotter.add_mesh(surf, color=FACES_RGB, ambient=0.5, pickable=False,
                                   name="qa-char-faces", render=False, reset_camera=False))
        # The faces' outlines: their boundaries and sharp edges (a hole's rims).
        edges = surf.clean().extract_feature_edges(feature_angle=30, boundary_edges=True,
                                                   feature_edges=True, manifold_edges=False,
                                                   non_manifold_edges=False)
        if edges.n_cells:
            _in_front(plotter.add_mesh(edges, color=EDGES_RGB, line_width=3, pickable=False,
                                       name="qa-char-edges", render=False,
                                       reset_camera=False))
    datum_faces = sorted({f for d in h.datums for f in d.faces} - set(h.faces))
    if faces is not None and datum_faces:
        _in_front(plotter.add_mesh(_surface(faces, datum_faces), color=DATUM_RGB,
                                   opacity=DATUM_OPACITY, pickable=False, name="qa-datum-faces",
                                   render=False, reset_camera=False))
    flags = [d for d in h.datums if np.all(np.isfinite(d.at))]
    if flags:
        plotter.add_point_labels(
            np.array([d.at for d in flags]), [d.label for d in flags], font_size=18, bold=True,
            text_color="white", shape_color=DATUM_RGB, shape_opacity=1.0, margin=4,
            point_color=DATUM_RGB, point_size=8, always_visible=True, name="qa-datum-flags",
            render=False, reset_camera=False)
    if not np.all(np.isfinite(h.at)):
        return
    plotter.add_points(np.array([h.at]), color=EDGES_RGB, point_size=10,
                       render_points_as_spheres=True, pickable=False, name="qa-anchor",
                       render=False, reset_camera=False)
    mapper = vtkImageMapper()
    mapper.SetInputData(_image_data(frame_image(h)))
    mapper.SetColorWindow(255.0)
    mapper.SetColorLevel(127.5)
    actor = vtkActor2D()
    actor.SetMapper(mapper)
    at = actor.GetPositionCoordinate()
    at.SetCoordinateSystemToDisplay()
    at.SetValue(*FRAME_OFFSET)
    world = vtkCoordinate()
    world.SetCoordinateSystemToWorld()
    world.SetValue(*h.at)
    at.SetReferenceCoordinate(world)
    plotter.renderer.add_actor(actor, name="qa-frame", pickable=False, render=False,
                               reset_camera=False)


def facing(faces: PartFaces, ids, back) -> float:
    """How squarely the faces ``ids`` face a camera looking along -``back`` (unit (3,)): the
    area-weighted mean |cos| between their triangles' normals and ``back`` (0: edge-on)."""
    V = faces.points[faces.triangles[faces.triangles_of(ids)]]
    n = np.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0])  # |n| is twice the area
    area = np.linalg.norm(n, axis=1)
    return float(np.abs(n @ np.asarray(back, float)).sum() / area.sum()) if area.sum() else 1.0


def face_at(plotter, x: int, y: int, cell_faces: np.ndarray | None,
            faces: PartFaces | None) -> int | None:
    """The id of the nominal's face under display pixel (x, y) (VTK's: from the bottom left),
    None where there is none. cell_faces : the face of each cell of the nominal's display
    surface (None when it was simplified: the face of the tessellation point nearest the
    pick stands in)."""
    from vtkmodules.vtkRenderingCore import vtkCellPicker

    actor = plotter.renderer.actors.get("qa-nominal")
    if actor is None or faces is None:
        return None
    picker = vtkCellPicker()
    picker.SetTolerance(0.0)
    picker.PickFromListOn()
    picker.AddPickList(actor)
    # The nominal is not pickable (a click picks the measured points): only for this pick.
    was = actor.GetPickable()
    actor.SetPickable(True)
    try:
        hit = picker.Pick(x, y, 0, plotter.renderer) and picker.GetCellId() >= 0
    finally:
        actor.SetPickable(was)
    if not hit:
        return None
    cell = picker.GetCellId()
    if cell_faces is not None and cell < len(cell_faces):
        return int(cell_faces[cell])
    near = int(np.argmin(np.linalg.norm(faces.points - picker.GetPickPosition(), axis=1)))
    return int(faces.triangle_faces[np.flatnonzero((faces.triangles == near).any(axis=1))[0]])
