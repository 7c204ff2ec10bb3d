"""A characteristic shown on the part (issue 26), decided without Qt
(qa_app.desktop.part_view): selecting a characteristic of CTC-01 inspected with its QIF plan
(or a TOML plan on its face ids) yields exactly its region's STEP faces, its points, its datums'
faces with their flags, its feature control frame and the camera's target; deselecting yields
nothing; a face is named by its id, surface and name."""

import numpy as np
import pytest

from ctc01 import DATUMS, QIF, SLOT, STP, measured_csv, tessellation_faces, toml_plan
from engine.gdt.plan import Characteristic
from qa_app.desktop.controller import Controller
from qa_app.desktop.model import Session
from qa_app.desktop.part_view import PartView, frame_note, frame_text


def inspected(nominal, measured, plan):
    s = Session()
    c = Controller(s, synchronous=True)
    c.open_files([nominal, measured])
    c.open_plan(plan)
    c.inspect()
    assert s.run is not None, "the inspection failed"
    view = PartView(s)
    shown = []
    view.changed.connect(shown.append)
    return s, view, shown


@pytest.fixture(scope="module")
def ctc01_qif(tmp_path_factory):
    return inspected(STP, measured_csv(tmp_path_factory.mktemp("ctc01")), QIF)


def row_of(s, cid):
    return [r.characteristic.id for r in s.run.result.plan.characteristics].index(cid)


def test_selecting_characteristic_1443_of_ctc01_yields_its_faces_datums_and_frame(ctc01_qif):
    s, view, shown = ctc01_qif
    row = row_of(s, "1443")
    s.select_characteristic(row)
    h = shown[-1]
    assert h is view.current and h.id == "1443" and h.row == row
    assert h.faces == SLOT == (38, 42)
    assert {d.label: d.faces for d in h.datums} == DATUMS
    assert [d.label for d in h.datums] == ["A", "B", "C"]  # primary first
    assert h.frame == "⌖ 0.75 | A | B | C" and h.note == "width"
    planned = s.run.result.plan.characteristics[row]
    assert np.array_equal(h.points, planned.indices) and h.points.size > 0
    # The flags stand at their faces' centres: datum B's and C's on their holes' axes.
    flags = {d.label: np.array(d.at) for d in h.datums}
    assert np.allclose(flags["B"][:2], (-325.0, -175.0)) and np.allclose(flags["C"][:2],
                                                                        (325.0, -175.0))
    # The frame stands at the slot, which the camera frames whole.
    faces = view.faces
    lo, hi = faces.extent(SLOT)
    assert np.all(np.array(h.at) >= lo - 1e-9) and np.all(np.array(h.at) <= hi + 1e-9)
    assert np.allclose(h.centre, 0.5 * (lo + hi))
    assert h.radius >= 0.5 * np.linalg.norm(hi - lo)
    s.select_characteristic(None)  # deselecting: nothing shown
    assert shown[-1] is None and view.current is None


def test_selecting_exactly_highlights_the_faces_of_the_characteristic(ctc01_qif):
    """Every characteristic of the QIF plan: its faces are those the plan mapped its regions to
    (the JSON's plan_faces), and the triangles drawn for them are exactly the tessellation's
    triangles of those faces (the STEP model read again, apart from the app)."""
    s, view, shown = ctc01_qif
    mapped = s.run.result.extra["plan_faces"]["regions"]
    tris, tri_face = tessellation_faces()
    for row, planned in enumerate(s.run.result.plan.characteristics):
        s.select_characteristic(row)
        h = shown[-1]
        c = planned.characteristic
        want = sorted({f for r in c.all_regions for f in mapped[s.run.plan.region(r).group]})
        assert list(h.faces) == want, c.id
        drawn = view.faces.triangles[view.faces.triangles_of(h.faces)]
        expected = tris[np.isin(tri_face, want)]
        assert sorted(map(tuple, drawn)) == sorted(map(tuple, expected)), c.id
        datum_region = {d.label: d.region for d in s.run.plan.datums}
        assert {d.label: list(d.faces) for d in h.datums} == {
            label: sorted(mapped[s.run.plan.region(datum_region[label]).group])
            for label in c.datums}
    s.select_characteristic(None)


def test_a_new_run_or_no_plan_shows_nothing(ctc01_qif):
    s, view, shown = ctc01_qif
    s.select_characteristic(0)
    assert shown[-1] is not None
    run = s.run
    s.set_run(None)
    assert shown[-1] is None and view.faces is None
    s.set_run(run)
    assert shown[-1] is None and view.faces is not None


def test_a_face_is_named_by_its_id_surface_and_name(ctc01_qif):
    s, view, _ = ctc01_qif
    assert view.face_text(25) == "face 25 · plane · (unnamed)"
    assert view.face_text(90).startswith("face 90 · cylinder · ")
    assert view.face_text(None) == "" and view.face_text(0) == "" and view.face_text(10_000) == ""


def test_a_toml_plan_on_face_ids_highlights_its_groups_faces(tmp_path):
    s, view, shown = inspected(STP, measured_csv(tmp_path, n=1200), toml_plan(tmp_path))
    s.select_characteristic(row_of(s, "7"))
    h = shown[-1]
    assert h.faces == SLOT and {d.label: d.faces for d in h.datums} == DATUMS
    assert h.frame == "⌖ 0.75 | A | B | C"
    s.select_characteristic(row_of(s, "8"))
    h = shown[-1]
    assert h.faces == (98,) and h.datums == () and h.frame == "⏥ 0.2"


def test_a_mesh_nominal_has_no_faces_the_frame_stands_at_the_points():
    import os

    bracket = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                           "samples", "seat_bracket")
    s, view, shown = inspected(os.path.join(bracket, "nominal.xyz"),
                               os.path.join(bracket, "measured.csv"),
                               os.path.join(bracket, "plan.toml"))
    s.select_characteristic(3)  # the hole's position
    h = shown[-1]
    assert view.faces is None and h.faces == () and h.datums[0].faces == ()
    assert not np.all(np.isfinite(h.datums[0].at))  # no face: no flag
    feet = s.run.result.deviations.foot[h.points]
    assert np.allclose(h.centre, 0.5 * (feet.min(axis=0) + feet.max(axis=0)))
    assert h.frame == "⌖ ⌀0.1 | A | B | C"


@pytest.mark.parametrize("c, frame, note", [
    (Characteristic("1", "position", "h", 0.0, 0.75, ("A", "B", "C")), "⌖ ⌀0.75 | A | B | C", ""),
    (Characteristic("2", "position", "h", 0.0, 0.1, ("A",), modifier="MMC",
                    regions=("h", "k", "l", "m")), "⌖ ⌀0.1 Ⓜ | A", "pattern of 4"),
    (Characteristic("3", "size", "h", -0.1, 0.05, nominal=20.0), "⌀20 -0.1/+0.05", ""),
    (Characteristic("4", "profile", "s", -0.05, 0.05, ("A", "B")), "⌓ 0.1 | A | B", ""),
    (Characteristic("5", "profile", "s", -0.02, 0.08), "⌓ 0.1 (-0.02/+0.08)", ""),
    (Characteristic("6", "flatness", "t", 0.0, 0.2), "⏥ 0.2", ""),
    (Characteristic("7", "perpendicularity", "w", 0.0, 1.5, ("A",)), "⟂ 1.5 | A", "plane"),
])
def test_the_feature_control_frame_text(c, frame, note):
    assert frame_text(c) == frame and frame_note(c) == note
