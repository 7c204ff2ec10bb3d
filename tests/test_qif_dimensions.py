"""The NIST FTC-06 part's dimensions read from its QIF (engine.io.qif_dimensions): its
tolerances stated in inches by the file's PMILinearUnit, its fillet radii and its "4X"
distances paired as the drawing means them (pairs written here from the file's feature
locations), and on points sampled on its exact faces in a random pose each value at the STEP
faces' own geometry, then one pad moved past its limit rejecting that distance only."""

import json
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from qa_app.cli import main

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")
QIF = os.path.join(DATA, "qif", "NISTmodels__nist_ftc_06_asme1_ap242.qif")
STP = os.path.join(DATA, "step", "nist_ftc_06_asme1_ap242-e1.stp")
Q = "{http://qifstandards.org/xsd/qif3}"
INCH = 25.4
PAIRS = {  # (first, second) QIF feature ids, read off the features' Location in the file
    "3716": [("3575", "3626"), ("3575", "3627"), ("3575", "3628"), ("3575", "3629")],
    "3720": [("3643", "3642"), ("3645", "3644")],   # x = -127 with -84.1, 127 with 84.1
    "3728": [("3687", "3688"), ("3689", "3690"), ("3691", "3692"), ("3693", "3694")],
}
"""One plane 0.5" above four pads; two pairs of steps 0.56"; four steps 0.31" deep."""


def _texts(cid: str) -> tuple[float, float, float]:
    """(TargetValue, MinValue, MaxValue) of characteristic ``cid`` as the XML writes them."""
    root = ET.parse(QIF).getroot()
    index = {e.get("id"): e for e in root.iter() if e.get("id")}
    e = index[cid]
    d = index[e.findtext(Q + "CharacteristicDefinitionId")]
    return (float(e.findtext(Q + "TargetValue")), float(d.findtext(f"{Q}Tolerance/{Q}MinValue")),
            float(d.findtext(f"{Q}Tolerance/{Q}MaxValue")))


def test_its_tolerances_are_read_in_inches_as_its_pmi_unit_says():
    from engine.io.qif_plan import read_qif_plan

    root = ET.parse(QIF).getroot()
    units = root.find(f"{Q}FileUnits/{Q}PrimaryUnits")
    assert units.findtext(f"{Q}LinearUnit/{Q}UnitName") == "mm"
    assert units.findtext(f"{Q}PMILinearUnit/{Q}UnitName") == "inch"
    plan = read_qif_plan(QIF)
    chars = {c.id: c for c in plan.characteristics}
    for cid in ("3730", "3732", "3734", "3716.1", "3720.2", "3728.4", "2398.1"):
        target, low, high = _texts(cid.split(".")[0])  # no linearUnit: the PMI unit, inches
        c = chars[cid]
        assert (c.nominal, c.lower, c.upper) == pytest.approx((target * INCH, low * INCH,
                                                               high * INCH), abs=1e-9), cid
    assert chars["3730"].nominal == pytest.approx(304.8)  # a 12" width, not 12 mm


def test_its_radii_and_4x_distances_map_to_their_features():
    from engine.io.qif_plan import read_qif_plan

    plan = read_qif_plan(QIF)
    got: dict[str, list] = {}
    for c in plan.characteristics:
        if c.type == "distance":
            got.setdefault(c.id.split(".")[0], []).append(tuple(r[4:] for r in c.regions))
            assert c.features == ("plane", "plane")
    assert got == PAIRS
    radii = [c for c in plan.characteristics if c.type == "radius"]
    assert [(c.id, c.region, c.kind) for c in radii] == [("2398.1", "qif:3705", None),
                                                        ("2398.2", "qif:3706", None)]
    not_judged = {n.id: n.reason for n in plan.not_judged}
    assert "toroidal segment" in not_judged["2467"]  # its 6 fillets of a torus among 24
    assert "informational" in not_judged["2464"] and "edges" in not_judged["3740"]


def test_its_perpendicularity_of_a_width_is_judged_on_the_widths_median_plane():
    """Perpendicularity.1 (id 2476) of the 12" width (OppositeParallelPlanes 3568) to A was
    left out ("perpendicularity of opposite parallel planes features is not judged yet"): it
    is a perpendicularity of the width's median plane, in a zone between two planes."""
    from engine.io.qif_plan import read_qif_plan

    plan = read_qif_plan(QIF)
    (c,) = [c for c in plan.characteristics if c.id == "2476"]
    assert (c.type, c.region, c.kind, c.diametral, c.datums) == (
        "perpendicularity", "qif:3568", "width", False, ("A",))
    assert c.feature == "width" and c.upper == pytest.approx(0.012 * INCH)
    assert "2476" not in {n.id for n in plan.not_judged}


def _sample(step, rng, n, faces):
    """n points on the B-rep, those of ``faces`` 40 times as dense (they are small)."""
    from sweep import face_areas

    ps = step.point_set
    area, face = face_areas(step)
    weight = area * np.where(np.isin(face, list(faces)), 40.0, 1.0)
    tri = ps.triangles[rng.choice(len(area), n, p=weight / weight.sum())]
    w = rng.dirichlet(np.ones(3), n)
    _, P, N, F = step.deviations(np.einsum("ij,ijk->ik", w, ps.points[tri]))
    return P, N, np.asarray(F)


def _inspect(tmp_path, P, R, t):
    np.savetxt(tmp_path / "m.csv", P @ R.T + t, delimiter=",", header="x,y,z", comments="",
               fmt="%.9f")
    main(["inspect", STP, str(tmp_path / "m.csv"), "--plan", QIF, "--json",
          str(tmp_path / "r.json"), "--quiet"])
    return json.loads((tmp_path / "r.json").read_text())


def test_measured_on_its_exact_faces_then_a_pad_moved_past_its_limit(tmp_path):
    """Each radius is its fillet's exact radius and each distance the distance of its two
    exact faces (OpenCascade's, via the STEP reader's face geometry), all ACCEPT; one pad of
    the 0.5" ±0.02" distance moved 0.6 mm away: that distance REJECTs (12.7 + 0.6), the other
    dimensions stay ACCEPT."""
    from engine.io.qif_plan import qif_face_groups
    from engine.io.step import read_step
    from step_models import random_pose

    step = read_step(STP)
    groups = qif_face_groups(QIF, step)
    dims = [g for g in groups if g[4:] in {f for p in PAIRS.values() for x in p for f in x}
            | {"3705", "3706"}]
    faces = {f for g in dims for f in groups[g]}
    rng = np.random.default_rng(3)
    P, N, F = _sample(step, rng, 40000, faces)
    P = P + rng.normal(0.0, 1e-4, len(P))[:, None] * N
    R, t = random_pose(5)
    doc = _inspect(tmp_path, P, R, t)
    chars = {c["id"]: c for c in doc["characteristics"]}
    geometry = {f.id: f.geometry for f in step.faces}
    for cid, pairs in PAIRS.items():
        for k, (a, b) in enumerate(pairs, start=1):
            (fa,), (fb,) = groups[f"qif:{a}"], groups[f"qif:{b}"]
            ga, gb = geometry[fa], geometry[fb]
            expected = abs((np.asarray(ga["point"]) - np.asarray(gb["point"]))
                           @ np.asarray(gb["normal"]))
            c = chars[f"{cid}.{k}"]
            assert c["value"] == pytest.approx(expected, abs=2e-4), c
            assert c["verdict"] == "ACCEPT" and c["unit"] == "mm", c
    for k, region in enumerate(("qif:3705", "qif:3706"), start=1):
        (face,) = groups[region]
        c = chars[f"2398.{k}"]
        assert c["value"] == pytest.approx(geometry[face]["radius"], abs=2e-4), c
        assert c["verdict"] == "ACCEPT", c
    # The second pad of 3716 (QIF feature 3627) moved 0.6 mm along its normal, away.
    (pad,) = groups["qif:3627"]
    moved = P.copy()
    on = F == pad
    assert on.sum() > 20
    moved[on] += 0.6 * N[on] * np.sign(
        (np.asarray(geometry[pad]["point"]) - np.asarray(geometry[groups["qif:3575"][0]]
                                                          ["point"])) @ N[on][0])
    doc = _inspect(tmp_path, moved, R, t)
    out = {c["id"]: c["value"] for c in doc["characteristics"]
           if c["verdict"] == "REJECT" and c["type"] in ("distance", "radius")}
    assert out == {"3716.2": pytest.approx(12.7 + 0.6, abs=2e-3)}
