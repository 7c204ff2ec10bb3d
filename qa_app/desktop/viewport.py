"""The 3D viewport (pyvistaqt): the nominal surface with the registered points coloured by
deviation on the tolerance-banded scale (or, after a plan's run, by the plan region each point
belongs to), standard views, point picking, the selected point's marker, and a characteristic's
points shown in their colours with the others faded, with, on a STEP nominal, what
part_view.PartView decides of it (its faces, datums and frame: part_overlay draws them) and the
name of the face the mouse rests on. Where OpenGL cannot show a window (Qt's
offscreen platform), a notice takes its place and the rest of the window works on.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import QTimer, Signal
from PySide6.QtWidgets import QCheckBox, QHBoxLayout, QLabel, QPushButton, QVBoxLayout, QWidget

from reports import figures
from reports.callouts import callout_points
from reports.figures.colours import UNCOVERED_RGB
from reports.messages import VERDICT_WORD

from . import part_overlay
from .model import Session, characteristic_rows
from .part_view import Highlight, PartView, part_faces

STANDARD_VIEWS = ("Face-on", "Iso", "Top", "Front", "Side")
FLAGS = 5
"""At most this many flags: the worst point of each separate cluster (reports.callouts)."""
FRAME_MARGIN = 1.1
"""The whole part framed, with this much room around it."""
ZOOM_SHARE = 0.12
"""Zoomed to a point, the view spans this share of the part's size."""
EDGE_ON, TILT_DEGREES = 0.35, 40.0
"""A characteristic's faces seen this edge-on (part_overlay.facing) are looked at from this much
lower (a hole's or a slot's walls seen from above)."""
HOVER_MS = 250
"""The mouse resting this long over a face tells which it is (``face_hovered``)."""


def can_render_3d() -> bool:
    from PySide6.QtGui import QGuiApplication

    return QGuiApplication.platformName() not in ("offscreen", "minimal")


class Viewport3D(QWidget):
    READOUT_HINT = "Click a point to see its label and deviation"
    FADED_RGB = (0.70, 0.71, 0.73)
    """The points outside the selected characteristic."""

    face_hovered = Signal(str)
    """The face under the resting mouse in words ("face 25 · plane · (unnamed)"), "" for
    none (a STEP nominal's; part_view.PartView.face_text)."""

    colouring_changed = Signal(object)
    """The regions' legend (reports.figures.region_colours) when the points show their plan
    regions, None when they show their deviations."""

    def __init__(self, session: Session, enable_3d: bool | None = None):
        super().__init__()
        self.session = session
        self.plotter = None
        self._shown = None  # (n, 3) displayed point positions
        self._colours = None  # the prepared display: "rgb", "regions"
        self._home = None  # (view vector, view up) of the face-on view
        self._tree = None
        self.part_view: PartView | None = None
        self.highlight: Highlight | None = None
        """The characteristic shown on the part (part_view.Highlight), or None."""
        self._camera_before = None  # the view before a characteristic was zoomed to
        self._hover_at = (0, 0)
        self._hover_timer = QTimer(self, singleShot=True, interval=HOVER_MS)
        self._hover_timer.timeout.connect(lambda: self.hover_at(*self._hover_at))
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        bar = QHBoxLayout()
        self.view_buttons = {}
        for name in STANDARD_VIEWS:
            b = QPushButton(name)
            b.setToolTip(f"{name} view")
            b.clicked.connect(lambda _=False, n=name: self.standard_view(n))
            bar.addWidget(b)
            self.view_buttons[name] = b
        self.regions_box = QCheckBox("Regions")
        self.regions_box.setToolTip("Colour the points by the plan region they belong to "
                                    "(each measured point joins the region of the nominal "
                                    "surface it lies on)")
        self.regions_box.setVisible(False)
        self.regions_box.toggled.connect(self._colouring)
        bar.addWidget(self.regions_box)
        self.surface_box = QCheckBox("Surface")
        self.surface_box.setToolTip("Colour the nominal surface by the deviations where the "
                                    "points cover it (each spot the colour of its nearest "
                                    "measured point); grey where nothing was measured")
        self.surface_box.setChecked(True)
        self.surface_box.setVisible(False)
        self.surface_box.toggled.connect(self._surface_colouring)
        bar.addWidget(self.surface_box)
        self.points_box = QCheckBox("Points")
        self.points_box.setToolTip("Show the measured points")
        self.points_box.setChecked(True)
        self.points_box.toggled.connect(self._colouring)
        bar.addWidget(self.points_box)
        self.readout = QLabel(self.READOUT_HINT)
        # Wrapped, so that a long label does not set the window's minimum width.
        self.readout.setWordWrap(True)
        bar.addWidget(self.readout, 1)
        lay.addLayout(bar)
        if enable_3d if enable_3d is not None else can_render_3d():
            from pyvistaqt import QtInteractor

            # No auto-update timer: with 200,000 points a frame costs ~0.3 s of the GUI thread,
            # so frames are drawn only when something changed.
            self.plotter = QtInteractor(self, auto_update=False)
            self.plotter.set_background("white")
            self.plotter.enable_point_picking(callback=self._picked, show_message=False,
                                              left_clicking=True, show_point=False,
                                              use_picker=True)
            self.plotter.iren.add_observer("MouseMoveEvent", self._mouse_moved)
            lay.addWidget(self.plotter.interactor, 1)
        else:
            notice = QLabel("The 3D view needs an OpenGL display; the table, 2D view and "
                            "certificate work without it.")
            notice.setWordWrap(True)
            lay.addWidget(notice, 1)
        session.result_changed.connect(self.show_run)
        session.selection_changed.connect(self._selected)
        session.characteristic_changed.connect(self._characteristic)

    def close_plotter(self) -> None:
        if self.plotter is not None:
            self.plotter.close()
            self.plotter = None

    @staticmethod
    def prepare(run) -> dict:
        """What the view needs of a run, computed in the worker thread (no OpenGL here): the
        display surface (simplified when big), point positions, colours, the pick tree and the
        face-on view. Keeps the GUI thread free for drawing."""
        from scipy.spatial import cKDTree

        res = run.result
        d = res.deviations.signed
        planned = getattr(res, "plan", None)
        out = {"rgb": figures.band_rgb(d, res.tolerance), "surface": None, "contours": None,
               "regions": None if planned is None else figures.region_colours(planned.regions)}
        lift = 0.0
        if run.template is not None:
            out["shown"] = res.registered.copy()
            out["contours"] = [np.column_stack([p, np.zeros(len(p))])
                               for p in figures.template_polylines(run.template.template)]
            out["home"] = ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0))
        else:
            nom = run.nominal
            # Bare points get a display mesh as on the certificate (reports.mapviews).
            surf, lift = figures.display_surface(
                nom.points, nom.triangles, max_triangles=400_000,
                normals=None if nom.triangles is not None else nom.normals(np.arange(nom.n)))
            if surf is not None:
                surf = surf.compute_normals(split_vertices=False, auto_orient_normals=False)
            out["surface"] = surf
            out["shown"] = res.deviations.foot + lift * res.deviations.normal
            face = figures.face_on_direction(res.deviations.foot, res.deviations.normal)
            out["home"] = (tuple(face), tuple(figures.any_perpendicular(face)))
        out["faces"] = faces = part_faces(run)
        # Each display cell's STEP face, for the hover (None once the surface is simplified).
        out["cell_faces"] = (faces.triangle_faces if faces is not None and out["surface"]
                             is not None and out["surface"].n_cells == len(faces.triangles)
                             else None)
        # The surface coloured by the deviations over the measured coverage (issue 26).
        out["coloured"], out["coloured_faces"] = (None, None) if out["surface"] is None else \
            figures.coloured_surface(out["surface"], res.deviations.foot, d, res.tolerance,
                                     lift, cell_faces=out["cell_faces"])
        out["tree"] = cKDTree(out["shown"])
        out["flags"] = np.array(callout_points(out["shown"], d, res.tolerance.lower,
                                               res.tolerance.upper, max_callouts=FLAGS), int)
        return out

    def show_run(self, run) -> None:
        self._shown = self._tree = self._colours = None
        self.highlight = self._camera_before = None
        self.readout.setText(self.READOUT_HINT)  # the picked point was the last run's
        if self.plotter is not None:
            # Remove our actors by name: Plotter.clear() would also remove the lights.
            for name in list(self.plotter.renderer.actors):
                if name.startswith("qa-"):
                    self.plotter.remove_actor(name, render=False)
        if run is None:
            self.regions_box.setVisible(False)
            self.colouring_changed.emit(None)
            if self.plotter is not None:
                self._redraw()
            return
        disp = self.session.display or self.prepare(run)
        self._shown, self._tree, self._home = disp["shown"], disp["tree"], disp["home"]
        self._colours = disp
        self.regions_box.setVisible(disp["regions"] is not None)
        self.surface_box.setVisible(disp.get("coloured") is not None)
        self.colouring_changed.emit(self.regions_legend())
        if self.plotter is None:
            return
        import pyvista as pv

        pl = self.plotter
        if disp["contours"] is not None:
            for k, pts in enumerate(disp["contours"]):
                pl.add_mesh(pv.lines_from_points(pts), color=(0.25, 0.25, 0.28), line_width=2,
                            name=f"qa-contour-{k}", pickable=False, render=False)
        elif disp["surface"] is not None:
            self._add_nominal()
            self._draw_nominal()
        else:
            step = max(1, run.nominal.points.shape[0] // 500_000)
            pl.add_points(run.nominal.points[::step], color=(0.72, 0.73, 0.75), point_size=2,
                          pickable=False, name="qa-nominal", render=False)
        self._draw_points()
        self._draw_flags()
        self.home_view()

    def flag_texts(self) -> list[tuple[int, str]]:
        """The flags of the run shown: (point index, text: its label and deviation, mm)."""
        run = self.session.run
        if run is None or self._colours is None:
            return []
        d = run.result.deviations.signed
        return [(int(i), f"{self.point_name(int(i))} {d[i]:+.3f}")
                for i in self._colours["flags"]]

    def point_name(self, index: int) -> str:
        """The point's label, else its number counting from 1 (as the table shows it)."""
        labels = self.session.run.measured.labels
        return str(labels[index]) if labels is not None else f"#{index + 1}"

    def _draw_flags(self) -> None:
        """A flag on the worst point of each separate cluster of notable points."""
        flags = self.flag_texts()
        if not flags:
            return
        self.plotter.add_point_labels(
            self._shown[[i for i, _ in flags]], [t for _, t in flags], font_size=13,
            bold=True, text_color="black", shape_color="white", shape_opacity=0.85,
            margin=3, point_color="magenta", point_size=6, render_points_as_spheres=True,
            always_visible=True, name="qa-flags", render=False, reset_camera=False)

    def zoom_to(self, index: int) -> None:
        """Centre the view on point ``index`` and come close, keeping the direction of view."""
        if self.plotter is None or self._shown is None:
            return
        cam = self.plotter.camera
        p = self._shown[index]
        back = np.subtract(cam.position, cam.focal_point)
        back /= np.linalg.norm(back) or 1.0
        size = float(np.linalg.norm(np.ptp(self._shown, axis=0))) or 1.0
        dist = 0.5 * ZOOM_SHARE * size / np.tan(np.radians(0.5 * cam.view_angle))
        cam.focal_point = tuple(p)
        cam.position = tuple(p + dist * back)
        self.plotter.renderer.reset_camera_clipping_range()
        self._redraw()

    def regions_legend(self):
        """The regions' legend while the points show their regions, else None."""
        regions = None if self._colours is None else self._colours["regions"]
        return regions[0] if regions is not None and self.regions_box.isChecked() else None

    def surface_coloured(self) -> bool:
        """Whether the nominal is drawn coloured by the deviations (else grey: also while a
        characteristic is shown on the part, its faces over the faded rest, and while the
        points show their regions)."""
        return bool(self._colours is not None and self._colours.get("coloured") is not None
                    and self.surface_box.isChecked() and self.highlight is None
                    and not self.regions_box.isChecked())

    def _add_nominal(self) -> None:
        """Add the nominal's display surface: the one coloured over the coverage when there is
        one (:meth:`_draw_nominal` shows or hides its colours), else the grey one."""
        disp, pl = self._colours, self.plotter
        look = dict(color=UNCOVERED_RGB, smooth_shading=True, specular=0.2, ambient=0.25,
                    pickable=False, name="qa-nominal", render=False)
        if disp.get("coloured") is not None:
            actor = pl.add_mesh(disp["coloured"], scalars="rgb", rgb=True, **look)
            # Grey when its colours are hidden (pyvista gives a mesh with scalars its own).
            actor.GetProperty().SetColor(*UNCOVERED_RGB)
        else:
            pl.add_mesh(disp["surface"], **look)

    def _draw_nominal(self) -> None:
        """Show the nominal coloured over the coverage, or grey (the same actor: its colours
        shown or not), and the characteristic shown on it (part_overlay)."""
        pl = self.plotter
        if pl is None:
            return
        actor = pl.renderer.actors.get("qa-nominal")
        if actor is not None and self._colours is not None and \
                self._colours.get("coloured") is not None:
            actor.GetMapper().SetScalarVisibility(self.surface_coloured())
        part_overlay.draw(pl, None if self.part_view is None else self.part_view.faces,
                          self.highlight)

    def _surface_colouring(self) -> None:
        self._draw_nominal()
        self._redraw()

    def _colouring(self) -> None:
        self.colouring_changed.emit(self.regions_legend())
        self._draw_nominal()
        if self._draw_points():
            self._redraw()

    def _draw_points(self) -> bool:
        """(Re)draw the measured points: coloured by deviation or region; with a characteristic
        selected, its points larger and the others faded. False when there is nothing to draw."""
        run = self.session.run
        if self.plotter is None or run is None or self._shown is None:
            return False
        pl = self.plotter
        for name in ("qa-in", "qa-out", "qa-faded"):
            pl.remove_actor(name, render=False)
        if not self.points_box.isChecked():
            return True
        res = run.result
        n = res.deviations.signed.size
        legend = self.regions_legend()
        rgb = self._colours["rgb"] if legend is None else self._colours["regions"][1]
        out = ~res.in_tolerance
        size = float(np.clip(300.0 / np.sqrt(max(n, 1)), 3, 10))
        faded = np.zeros(n, dtype=bool)
        chosen = self.session.highlighted
        if chosen is not None:
            faded[:] = True
            faded[chosen] = False
            size *= 1.3
        for name, mask, px in (("qa-in", ~out & ~faded, size), ("qa-out", out & ~faded,
                                                                1.7 * size)):
            if mask.any():
                pl.add_points(self._shown[mask], scalars=rgb[mask], rgb=True,
                              render_points_as_spheres=True, point_size=px, name=name,
                              render=False)
        if faded.any():
            pl.add_points(self._shown[faded], color=self.FADED_RGB, point_size=0.5 * size,
                          render_points_as_spheres=True, name="qa-faded", render=False)
        return True

    def _characteristic(self, row) -> None:
        """A characteristic selected (row of model.characteristic_rows) or none: its points
        stand out, and the readout says what it is."""
        if row is None:
            self.readout.setText(self.READOUT_HINT)
        else:
            r = characteristic_rows(self.session.run)[row]
            ref = f" |{r.datums}" if r.datums != "—" else ""
            self.readout.setText(f"<b>[{r.id}] {r.type} of {r.region}{ref}</b>: {r.value}, "
                                 f"{r.requirement}, {r.points} points: "
                                 f"<b>{VERDICT_WORD[r.verdict]}</b>")
        if self._draw_points():
            self._redraw()

    def home_view(self) -> None:
        if self.plotter is None or self._home is None:
            return
        # One render at the end: each costs ~0.3 s for 200,000 points in software OpenGL.
        # The renderer's own methods: the Plotter's reset_camera always renders.
        self.plotter.renderer.view_vector(*self._home, render=False)
        self.frame_part()
        self._redraw()

    def frame_part(self) -> None:
        """Keep the direction of view and come as close as the whole part allows: its points'
        extent across the view fills the viewport's width or height, less a margin."""
        cam = self.plotter.camera
        back = np.subtract(cam.position, cam.focal_point)
        back /= np.linalg.norm(back)
        up = np.asarray(cam.up, float) - np.dot(cam.up, back) * back
        up /= np.linalg.norm(up)
        right = np.cross(up, back)
        pts = self._shown
        across = np.column_stack([pts @ right, pts @ up, pts @ back])
        lo, hi = across.min(axis=0), across.max(axis=0)
        mid = 0.5 * (lo + hi)
        w, h = self.plotter.window_size
        half = FRAME_MARGIN * max(0.5 * (hi[1] - lo[1]),
                                  0.5 * (hi[0] - lo[0]) * h / max(w, 1), 1e-9)
        dist = half / np.tan(np.radians(0.5 * cam.view_angle)) + 0.5 * (hi[2] - lo[2])
        centre = mid[0] * right + mid[1] * up + mid[2] * back
        cam.focal_point = tuple(centre)
        cam.position = tuple(centre + dist * back)
        self.plotter.renderer.reset_camera_clipping_range()

    def _redraw(self) -> None:
        """Ask Qt for a repaint (which renders once) instead of rendering now and again when Qt
        paints the widget."""
        QWidget.update(self.plotter.interactor)

    def standard_view(self, name: str) -> None:
        if self.plotter is None:
            return
        if name == "Face-on":
            self.home_view()
            return
        {"Iso": self.plotter.view_isometric, "Top": self.plotter.view_xy,
         "Front": self.plotter.view_xz, "Side": self.plotter.view_yz}[name](render=False)
        if self._shown is not None:
            self.frame_part()
        self._redraw()

    def _picked(self, point, *args) -> None:
        if self._tree is None or point is None:
            return
        _, i = self._tree.query(np.asarray(point, float))
        self.session.select(int(i))

    def _selected(self, index) -> None:
        run = self.session.run
        if index is None or run is None or self._shown is None:
            return
        name = self.point_name(index)
        d = run.result.deviations.signed[index]
        ok = "in tolerance" if run.result.in_tolerance[index] else "OUT OF TOLERANCE"
        if run.result.outlier[index]:
            ok += "; excluded from alignment (gross outlier)"
        self.readout.setText(f"<b>{name}</b>: deviation {d:+.4f} mm ({ok})")
        if self.plotter is not None:
            import pyvista as pv

            p = self._shown[index]
            r = 0.015 * float(np.linalg.norm(np.ptp(self._shown, axis=0)) or 1.0)
            self.plotter.add_mesh(pv.Sphere(radius=r, center=p), color="magenta",
                                  name="qa-selection", pickable=False, render=False)
            self._redraw()

    # ------------------------------------------------------------------ a characteristic on the part
    def use(self, part_view: PartView) -> None:
        """Show what ``part_view`` decides for the selected characteristic (its ``changed``)
        and name the faces hovered with it."""
        self.part_view = part_view
        part_view.changed.connect(self.show_highlight)

    def show_highlight(self, h: Highlight | None) -> None:
        """Show a characteristic on the part (part_view.Highlight): its faces over the faded
        nominal, its datums' faces and flags, its frame, zoomed to; None: the part as before,
        seen as before."""
        before, self.highlight = self.highlight, h
        if self.plotter is None or self._shown is None:
            return
        self._draw_nominal()  # grey under a characteristic; and the overlay (part_overlay)
        cam = self.plotter.camera
        if h is not None:
            if before is None:
                self._camera_before = (cam.position, cam.focal_point, cam.up)
            self.zoom_to_highlight(h)
        elif self._camera_before is not None:
            cam.position, cam.focal_point, cam.up = self._camera_before
            self._camera_before = None
            self.plotter.renderer.reset_camera_clipping_range()
        self._redraw()

    def zoom_to_highlight(self, h: Highlight) -> None:
        """Frame the characteristic's sphere (centre, radius) from the direction of view, or
        from higher up when its faces are seen edge-on (a hole's wall from above)."""
        cam = self.plotter.camera
        back = np.subtract(cam.position, cam.focal_point)
        back /= np.linalg.norm(back) or 1.0
        faces = None if self.part_view is None else self.part_view.faces
        if faces is not None and h.faces and part_overlay.facing(faces, h.faces, back) < EDGE_ON:
            cam.Elevation(-TILT_DEGREES)
            cam.OrthogonalizeViewUp()
            back = np.subtract(cam.position, cam.focal_point)
            back /= np.linalg.norm(back) or 1.0
        w, hgt = self.plotter.window_size
        half = np.radians(0.5 * cam.view_angle)
        # The view angle is the height's: a window wider than high frames the sphere by it.
        dist = h.radius / np.tan(half) * max(1.0, hgt / max(w, 1))
        cam.focal_point = h.centre
        cam.position = tuple(np.add(h.centre, dist * back))
        self.plotter.renderer.reset_camera_clipping_range()

    def _mouse_moved(self, iren, _event) -> None:
        self._hover_at = tuple(iren.GetEventPosition())
        self._hover_timer.start()

    def hover_at(self, x: int, y: int) -> str:
        """Name the face under display pixel (x, y) (VTK's, from the bottom left) through
        ``face_hovered``; returns the text ("" for none)."""
        if self.plotter is None or self.part_view is None or self._colours is None:
            return ""
        face = part_overlay.face_at(self.plotter, x, y, self._colours.get(
            "coloured_faces" if self._colours.get("coloured") is not None else "cell_faces"),
                                    self.part_view.faces)
        text = self.part_view.face_text(face)
        self.face_hovered.emit(text)
        return text
