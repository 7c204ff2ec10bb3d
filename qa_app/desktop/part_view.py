"""A characteristic shown on the part (issue 26): what the 3D view shows when a characteristic is
selected — its STEP faces, its measured points, its datums' faces with their flags, its feature
control frame, where to look — and what a face under the mouse is, decided here as plain data
(face ids, point indices, text, coordinates in the nominal frame, mm). The viewport draws it.
No Qt here (an import-linter contract): tested without a window.

The faces come from the run's STEP nominal (engine.pipeline.Run ``faces``): a plan region's
faces are those of the nominal samples it selects (engine.gdt.regions.nominal_members: a
``face:N`` group, a face's name, a QIF plan's feature, a box), so they are the plan's own, as
the JSON's ``plan_faces`` lists them for a QIF plan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from engine.gdt.plan import MODIFIERS, SYMBOLS

from .model import Event, Session

MATERIAL = dict(zip(MODIFIERS, ("", "Ⓜ", "Ⓛ")))
"""A tolerance's material condition as the frame writes it after the tolerance (RFS: none)."""
FOCUS_MARGIN = 1.6
"""Zoomed to a characteristic, the view spans this many times its faces' (or points') extent."""


@dataclass(frozen=True)
class PartFaces:
    """A run's STEP faces as the views look them up (made once per run, in the worker).

    faces : the face records (engine.io.step.StepFace), ``faces[i].id == i + 1``; points (n, 3)
    and triangles (m, 3): the nominal's tessellation (the run's nominal, nominal frame, mm);
    triangle_faces : (m,) the face of each triangle; regions : plan region name -> its face
    ids (ascending), for every region of the run's plan.
    """

    faces: tuple
    points: np.ndarray
    triangles: np.ndarray
    triangle_faces: np.ndarray
    regions: dict[str, tuple[int, ...]]

    def triangles_of(self, faces) -> np.ndarray:
        """Indices (ascending) of the triangles drawn for the faces ``faces`` (ids)."""
        return np.flatnonzero(np.isin(self.triangle_faces, np.asarray(list(faces), int)))

    def centroid(self, faces) -> np.ndarray:
        """(3,) the area-weighted centre of the faces' triangles, mm."""
        V = self.points[self.triangles[self.triangles_of(faces)]]
        if not len(V):
            return np.full(3, np.nan)
        area = 0.5 * np.linalg.norm(np.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0]), axis=1)
        centres = V.mean(axis=1)
        return (area @ centres / area.sum() if area.sum() > 0 else centres.mean(axis=0))

    def extent(self, faces) -> np.ndarray:
        """(2, 3) the bounding box (min, max) of the faces' triangles, mm."""
        P = self.points[np.unique(self.triangles[self.triangles_of(faces)])]
        return np.array([P.min(axis=0), P.max(axis=0)]) if len(P) else np.full((2, 3), np.nan)

    def describe(self, face_id: int) -> str:
        """"face 25 · plane · (unnamed)": the face's id, surface and name (its own, else
        "(unnamed)")."""
        f = self.faces[int(face_id) - 1]
        return f"face {f.id} · {f.surface} · {f.name or '(unnamed)'}"


def part_faces(run) -> PartFaces | None:
    """The faces of ``run``'s STEP nominal and its plan's regions' faces; None for another
    nominal (a mesh, points, a template)."""
    from engine.gdt.regions import nominal_members

    faces = getattr(run, "faces", None)
    if faces is None or run.nominal is None or run.nominal.triangles is None:
        return None
    ids = np.asarray(faces.face_ids)
    tris = run.nominal.triangles
    regions: dict[str, tuple[int, ...]] = {}
    if run.plan is not None:
        members = nominal_members(run.plan, run.nominal.points, None, faces.groups,
                                  triangles=tris)
        regions = {name: tuple(int(f) for f in np.unique(ids[mask]))
                   for name, mask in members.items()}
    return PartFaces(tuple(faces.faces), run.nominal.points, tris, ids[tris[:, 0]], regions)


def frame_text(c) -> str:
    """A characteristic's feature control frame as one line: its symbol and tolerance (with
    its material condition), then its datums, primary first: "⌖ ⌀0.75 | A | B | C". A size
    states its nominal and limits ("⌀20 -0.1/+0.05"), a profile its zone, and its limits only
    when the zone is not centred on the surface. c : engine.gdt.plan.Characteristic."""
    from reports.plan_table import tolerance_words

    tol = tolerance_words(c)
    if c.type in ("profile", "line_profile") and abs(c.lower + c.upper) <= 1e-12:
        tol = tol.split(" (")[0]  # "1.25 (-0.625/+0.625)": a centred zone is its width
    tol = tol + (f" {MATERIAL[c.modifier]}" if MATERIAL.get(c.modifier) else "")
    head = tol if c.type == "size" else f"{SYMBOLS.get(c.type, c.type)} {tol}"
    return " | ".join((head,) + tuple(c.datums))


def frame_note(c) -> str:
    """What else the frame's characteristic states, in words ("pattern of 4, all around"), less
    its material condition (in the frame); "" for nothing."""
    from reports.plan_table import modifier_words

    words = [w for w in modifier_words(c).split(", ") if w not in ("-",) + MODIFIERS]
    return ", ".join(words)


@dataclass(frozen=True)
class DatumFlag:
    """A datum the characteristic refers to: its label, its faces, where its flag stands (the
    faces' centre, mm; NaN when its region has no face)."""

    label: str
    faces: tuple[int, ...]
    at: tuple[float, float, float]


@dataclass(frozen=True)
class Highlight:
    """What the 3D view shows of the selected characteristic.

    row : its row (model.characteristic_rows); id : its balloon; type : its type (engine.gdt.
    plan.CHARACTERISTICS); faces : the STEP faces of its
    regions (ids; () without a STEP nominal); points : (k,) its measured points (indices);
    datums : its datums' flags, primary first; frame : its feature control frame's text
    (:func:`frame_text`), note : what else it states (:func:`frame_note`); at : where the frame
    stands (the faces' centre, else its points'), mm; centre and radius : what the camera
    frames (mm).
    """

    row: int
    id: str
    type: str
    faces: tuple[int, ...]
    points: np.ndarray
    datums: tuple[DatumFlag, ...]
    frame: str
    note: str
    at: tuple[float, float, float]
    centre: tuple[float, float, float]
    radius: float


def _tuple3(v) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def highlight(run, faces: PartFaces | None, row: int) -> Highlight:
    """What to show for characteristic ``row`` of ``run``'s plan result (model.characteristic_
    rows' order). Without faces (not a STEP nominal, or a region of none: the zone over all
    points) the frame stands at its points and the camera frames them."""
    r = run.result.plan.characteristics[row]
    c = r.characteristic
    regions = faces.regions if faces is not None else {}
    mine = tuple(sorted({f for name in c.all_regions for f in regions.get(name, ())}))
    datum_region = {d.label: d.region for d in (run.plan.datums if run.plan else ())}
    flags = []
    for label in c.datums:
        ids = regions.get(datum_region.get(label, ""), ())
        at = faces.centroid(ids) if faces is not None and ids else np.full(3, np.nan)
        flags.append(DatumFlag(label, ids, _tuple3(at)))
    points = np.asarray(r.indices, int)
    if faces is not None and mine:
        lo, hi = faces.extent(mine)
        at = faces.centroid(mine)
    else:
        feet = run.result.deviations.foot
        P = feet[points] if points.size else feet
        lo, hi = P.min(axis=0), P.max(axis=0)
        at = 0.5 * (lo + hi)
    radius = 0.5 * FOCUS_MARGIN * float(np.linalg.norm(hi - lo))
    size = float(np.linalg.norm(np.ptp(run.result.deviations.foot, axis=0))) or 1.0
    return Highlight(row, c.id, c.type, mine, points, tuple(flags), frame_text(c), frame_note(c),
                     _tuple3(at), _tuple3(0.5 * (lo + hi)), max(radius, 0.02 * size))


class PartView:
    """The controller's half of the 3D view's characteristic display: follows the session's
    characteristic (``Session.characteristic_changed``) and says what to show through
    ``changed(Highlight or None)``; answers what a face is (:meth:`face_text`). The faces are
    the display's (``session.display["faces"]``, made in the worker), else made here."""

    def __init__(self, session: Session):
        self.session = session
        self.changed = Event()
        self.current: Highlight | None = None
        self._faces: PartFaces | None = None
        self._run = None
        session.result_changed.connect(lambda run: self._select(None))
        session.characteristic_changed.connect(self._select)

    @property
    def faces(self) -> PartFaces | None:
        """The faces of the run on screen (None without a STEP nominal or a run)."""
        run = self.session.run
        if run is not self._run:
            self._run = run
            display = self.session.display
            self._faces = (display["faces"] if isinstance(display, dict) and "faces" in display
                           else None if run is None else part_faces(run))
        return self._faces

    def face_text(self, face_id: int | None) -> str:
        """The face ``face_id`` in words ("face 25 · plane · (unnamed)"), "" for none."""
        faces = self.faces
        if face_id is None or faces is None or not 1 <= face_id <= len(faces.faces):
            return ""
        return faces.describe(face_id)

    def _select(self, row) -> None:
        run = self.session.run
        if row is None or run is None or getattr(run.result, "plan", None) is None \
                or run.template is not None:
            h = None
        else:
            h = highlight(run, self.faces, row)
        self.current = h
        self.changed.emit(h)
