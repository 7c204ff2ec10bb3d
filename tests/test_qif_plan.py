"""Inspection plans read from a QIF 3.0 MBD (engine.io.qif_plan): the NIST CTC-01 and FTC-08
test parts' own QIF files (tests/data/qif, copied from ../shared/realdata/qif_samples) against
their STEP AP242 models (tests/data/step): the characteristics counted
independently, every mapped face checked on the exact surface with OpenCascade, an inspection
of points sampled on the exact faces in a random pose, and the refusals (exit 65)."""

import json
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from qa_app.cli import main

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")
QIF_DIR = os.path.join(DATA, "qif")  # copies of the shared folder's (SOURCE.txt there)
STEP_DIR = os.path.join(DATA, "step")
PARTS = {
    "CTC-01": ("NISTmodels__nist_ctc_01_asme1_ap242.qif", "nist_ctc_01_asme1_ap242-e1.stp"),
    "FTC-08": ("NISTmodels__nist_ftc_08_asme1_ap242-1.qif", "nist_ftc_08_asme1_ap242-e1.stp"),
}
QIF3 = "{http://qifstandards.org/xsd/qif3}"


def qif(part: str) -> str:
    return os.path.join(QIF_DIR, PARTS[part][0])


def stp(part: str) -> str:
    return os.path.join(STEP_DIR, PARTS[part][1])


@pytest.fixture(scope="module")
def steps():
    from engine.io.step import read_step

    cache = {}

    def get(part):
        if part not in cache:
            cache[part] = read_step(stp(part))
        return cache[part]

    return get


def xml_characteristics(path: str) -> list:
    """The file's characteristic nominals, found with the standard library's parser."""
    root = ET.parse(path).getroot()
    (noms,) = root.iter(QIF3 + "CharacteristicNominals")
    return list(noms)


def xml_geometry(path: str):
    """{feature nominal id: element}, {feature definition id: element}, the file's mm per
    length unit over its declared scale, by the standard library's parser."""
    root = ET.parse(path).getroot()
    features = {e.get("id"): e for e in root.find(QIF3 + "Features/" + QIF3 + "FeatureNominals")}
    definitions = {e.get("id"): e
                   for e in root.find(QIF3 + "Features/" + QIF3 + "FeatureDefinitions")}
    unit = root.find(f"{QIF3}FileUnits/{QIF3}PrimaryUnits/{QIF3}LinearUnit")
    mm = 1000.0 * float(unit.findtext(f"{QIF3}UnitConversion/{QIF3}Factor"))
    scale = float(root.findtext(f"{QIF3}Product/{QIF3}Header/{QIF3}ScaleCoefficient") or 1)
    return features, definitions, mm / scale


@pytest.mark.parametrize("part", sorted(PARTS))
def test_every_characteristic_is_read_and_each_mapped_one_has_faces(part, steps):
    from engine.io.qif_plan import qif_face_groups, read_qif_plan

    plan = read_qif_plan(qif(part))
    in_file = xml_characteristics(qif(part))
    assert plan.n_source == len(in_file) > 0
    read = {c.id.split(".")[0] for c in plan.characteristics} | {c.id for c in plan.not_judged}
    assert read == {e.get("id") for e in in_file}
    assert not {c.id.split(".")[0] for c in plan.characteristics} & {c.id for c in plan.not_judged}
    assert all(c.reason for c in plan.not_judged)
    groups = qif_face_groups(qif(part), steps(part))
    regions = {r.name: r.group for r in plan.regions}
    for c in plan.characteristics:
        assert len(groups[regions[c.region]]) >= 1
    for d in plan.datums:
        assert len(groups[regions[d.region]]) >= 1


SUPPORTED = {"SurfaceProfile", "Flatness", "Straightness", "Circularity", "Cylindricity",
             "Parallelism", "Perpendicularity", "Angularity", "Position", "Coaxiality",
             "Concentricity", "Symmetry", "CircularRunout", "TotalRunout", "Diameter", "Width",
             "SphericalDiameter", "Angle", "DistanceBetween", "Radius", "SphericalRadius"}
"""QIF characteristic kinds the plan layer has a type for (written here, not imported)."""
HELD_BACK = {
    "CTC-01": {},
    "FTC-08": {"4101": "datum G is 2 features", "4108": "datum K is at maximum material",
               "4136": "datum H is at maximum material",
               "4163": "maximum material condition is not judged",
               "7515": "informational: a distance between with no tolerance (measured)"},
}
"""Characteristics of a supported kind that stay not judged, and why: a datum made of two
features, a datum at MMC (datum shift), a perpendicularity at MMC, a reference dimension."""
COUNTS = {"CTC-01": (14, 0), "FTC-08": (32, 5)}
"""(judged, not judged) per part; before the QIF reader mapped form, orientation, runout,
widths, patterns and MMC: CTC-01 (10, 4), FTC-08 (18, 19); before angles, distances and radii:
CTC-01 (13, 1) (its 60° angle)."""


@pytest.mark.parametrize("part", sorted(PARTS))
def test_judged_and_not_judged_counts_follow_the_kinds_the_plan_supports(part):
    """Counted here by kind with the standard library: every characteristic of a supported
    kind is judged except the few held back for a stated reason; every other kind is listed
    as not judged, with its reason."""
    from engine.io.qif_plan import read_qif_plan

    plan = read_qif_plan(qif(part))
    kinds = {e.get("id"): e.tag[len(QIF3):-len("CharacteristicNominal")]
             for e in xml_characteristics(qif(part))}
    supported = {i for i, k in kinds.items() if k in SUPPORTED}
    judged = {c.id.split(".")[0] for c in plan.characteristics}
    not_judged = {c.id: c.reason for c in plan.not_judged}
    assert judged == supported - set(HELD_BACK[part])
    assert set(not_judged) == (set(kinds) - supported) | set(HELD_BACK[part])
    for cid, why in HELD_BACK[part].items():
        assert why in not_judged[cid], (cid, not_judged[cid])
    assert (len(judged), len(not_judged)) == COUNTS[part]


def _exact_surface(step, fid: int):
    """(kind, geometry) of STEP face ``fid`` from OpenCascade's exact surface."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_Cylinder, GeomAbs_Plane

    s = BRepAdaptor_Surface(step.face_shape(fid))
    if s.GetType() == GeomAbs_Plane:
        pln = s.Plane()
        return "plane", (np.array(pln.Location().Coord()), np.array(pln.Axis().Direction().Coord()))
    if s.GetType() == GeomAbs_Cylinder:
        cyl = s.Cylinder()
        return "cylinder", (np.array(cyl.Location().Coord()),
                            np.array(cyl.Axis().Direction().Coord()), cyl.Radius())
    return "other", None


@pytest.mark.parametrize("part", sorted(PARTS))
def test_mapped_faces_lie_on_their_qif_features_geometry(part, steps):
    """Each face a plane or cylinder feature maps to lies, on OpenCascade's exact surface, on
    the feature's own nominal plane (Location, Normal) or cylinder (Axis, the definition's
    Diameter), read from the XML here."""
    from engine.io.qif_plan import qif_face_groups, read_qif_plan

    step = steps(part)
    plan = read_qif_plan(qif(part))
    groups = qif_face_groups(qif(part), step)
    features, definitions, mm = xml_geometry(qif(part))
    tol = 1e-4 * float(np.linalg.norm(np.ptp(step.bounds, axis=0)))
    checked = 0
    for region in plan.regions:  # (a face of a feature, "ID/FACE": not its whole geometry)
        ids = [p.partition("/")[0] for p in region.group[4:].split("+")]
        if len(ids) != 1 or features[ids[0]].tag not in (QIF3 + "PlaneFeatureNominal",
                                                         QIF3 + "CylinderFeatureNominal"):
            continue
        e = features[ids[0]]
        for fid in groups[region.group]:
            kind, g = _exact_surface(step, fid)
            if e.tag == QIF3 + "PlaneFeatureNominal":
                p = np.array(e.findtext(QIF3 + "Location").split(), float) * mm
                n = np.array(e.findtext(QIF3 + "Normal").split(), float)
                assert kind == "plane"
                assert abs(abs(g[1] @ n) - 1.0) < 1e-8
                assert abs((g[0] - p) @ n) < tol
            else:
                axis = e.find(QIF3 + "Axis")
                p = np.array(axis.findtext(QIF3 + "AxisPoint").split(), float) * mm
                a = np.array(axis.findtext(QIF3 + "Direction").split(), float)
                a /= np.linalg.norm(a)
                d = float(definitions[e.findtext(QIF3 + "FeatureDefinitionId")]
                          .findtext(QIF3 + "Diameter")) * mm
                assert kind == "cylinder"
                assert abs(abs(g[1] @ a) - 1.0) < 1e-8
                off = g[0] - p
                assert np.linalg.norm(off - (off @ a) * a) < tol
                assert abs(2 * g[2] - d) < tol
            checked += 1
    assert checked >= 5


def write(path, M):
    np.savetxt(path, M, delimiter=",", header="x,y,z", comments="", fmt="%.9f")


def test_ctc01_measured_on_its_exact_faces_accepts_every_judged_characteristic(tmp_path, steps):
    """Points on CTC-01's exact faces, a random pose, 0.1 µm noise: every characteristic of
    the QIF is judged and ACCEPT (its value near 0, each size at its nominal, the 60° angular
    size between its two faces at 60°, in degrees), the perpendicularity and the two slots'
    positions among them; nothing is left not judged, so the part is ACCEPT (REJECT only for
    a size whose nominal is its limit, which the noise puts either side of it)."""
    from step_models import random_pose
    from sweep import on_part

    step = steps("CTC-01")
    rng = np.random.default_rng(7)
    P, N, _ = on_part(step, rng, 12000)
    P = P + rng.normal(0.0, 1e-4, len(P))[:, None] * N
    R, t = random_pose(11)
    write(tmp_path / "m.csv", P @ R.T + t)
    code = main(["inspect", stp("CTC-01"), str(tmp_path / "m.csv"), "--plan", qif("CTC-01"),
                 "--json", str(tmp_path / "r.json")])
    doc = json.loads((tmp_path / "r.json").read_text())
    chars = doc["characteristics"]
    assert len(chars) == 14
    assert {"1443", "1450", "1467", "1491"} <= {c["id"] for c in chars}
    on_limit_out = []
    for c in chars:
        if c["type"] == "size":
            # Planted at the nominal; where the nominal is a limit (CTC-01's ⌀35 -0.2/+0 and
            # +0/+0.2) the noise puts the fitted diameter on either side of it.
            assert c["value"] == pytest.approx(c["nominal"], abs=2e-4)
            if min(abs(c["lower"]), abs(c["upper"])) == 0.0:  # the result says so
                assert "on its " in c["reason"] and " limit (" in c["reason"], c
            if c["verdict"] != "ACCEPT":
                assert min(abs(c["lower"]), abs(c["upper"])) == 0.0, c
                on_limit_out.append(c["id"])
        elif c["type"] == "angle":  # 1491: between the two faces of QIF feature 2180
            assert c["id"] == "1491" and c["unit"] == "degree" and c["verdict"] == "ACCEPT", c
            assert c["value"] == pytest.approx(60.0, abs=1e-3)  # 0.1 µm noise, faces ~5 mm
            assert (c["nominal"], c["lower"], c["upper"]) == (60.0, -0.5, 0.5)
            assert c["regions"] == ["qif:2180/1296", "qif:2180/1314"]
        else:
            assert c["verdict"] == "ACCEPT", c
            assert c["value"] < 0.01
    assert doc["verdict"] == ("REJECT" if on_limit_out else "ACCEPT")
    assert code == (1 if on_limit_out else 0)
    # Ids follow the source (issue 25): each carries the QIF's Name, its Designator (the
    # drawing's balloon) and the element it was read from, as the standard library reads them.
    xml = {e.get("id"): e for e in xml_characteristics(qif("CTC-01"))}
    for c in chars:
        e = xml[c["id"]]
        assert c["name"] == e.findtext(QIF3 + "Name").strip()
        assert c["designator"] == e.find(QIF3 + "CharacteristicDesignator").findtext(
            QIF3 + "Designator").strip()
        assert c["source"] == {"file": os.path.basename(qif("CTC-01")),
                               "item": f"{e.tag[len(QIF3):]} {c['id']}"}
    for out in on_limit_out:  # the reason names it by its balloon, its name and its id
        c = next(c for c in chars if c["id"] == out)
        assert any(r.startswith(f"characteristic {c['designator']} (size; {c['name']}, id "
                                f"{out}) is out of tolerance") for r in doc["reasons"])
    assert doc["plan_faces"]["not_judged_summary"] == ""
    assert doc["plan_faces"]["not_judged"] == []
    assert not any("not judged" in r for r in doc["reasons"])


def _refused(capsys, nominal, measured, plan) -> str:
    code = main(["inspect", nominal, measured, "--plan", plan, "--json", "-"])
    assert code == 65
    return capsys.readouterr().err


@pytest.fixture
def measured(tmp_path):
    path = tmp_path / "m.csv"
    write(path, np.random.default_rng(0).uniform(-100, 100, (50, 3)))
    return str(path)


def test_a_qif_that_is_not_xml_is_refused(tmp_path, capsys, measured):
    bad = tmp_path / "part.qif"
    bad.write_bytes(Path(qif("CTC-01")).read_bytes()[:5000])
    err = _refused(capsys, stp("CTC-01"), measured, str(bad))
    assert "part.qif" in err and "is not valid XML" in err


def test_a_qif_2_file_is_refused(tmp_path, capsys, measured):
    text = Path(qif("CTC-01")).read_text("utf-8")
    old = tmp_path / "old.QIF"
    old.write_text(text.replace("http://qifstandards.org/xsd/qif3",
                                "http://qifstandards.org/xsd/qif2").replace(
                                    'versionQIF="3.0.0"', 'versionQIF="2.1.0"'), "utf-8")
    err = _refused(capsys, stp("CTC-01"), measured, str(old))
    assert "old.QIF" in err and "QIF 2.1.0" in err and "QIF 3.0" in err


def test_xml_entities_are_never_expanded(tmp_path, capsys, measured):
    bomb = tmp_path / "bomb.qif"
    bomb.write_text('<?xml version="1.0"?><!DOCTYPE q [<!ENTITY a "aaaaaaaaaa">'
                    '<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]>'
                    '<QIFDocument xmlns="http://qifstandards.org/xsd/qif3" versionQIF="3.0.0">'
                    '&b;</QIFDocument>')
    err = _refused(capsys, stp("CTC-01"), measured, str(bomb))
    assert "bomb.qif" in err and "DOCTYPE" in err


def test_a_qif_plan_needs_a_step_nominal(tmp_path, capsys, measured):
    nominal = tmp_path / "nominal.csv"
    write(nominal, np.random.default_rng(1).uniform(-100, 100, (50, 3)))
    err = _refused(capsys, str(nominal), measured, qif("CTC-01"))
    assert "NISTmodels__nist_ctc_01_asme1_ap242.qif" in err and "nominal.csv is no STEP" in err


def test_a_qif_whose_feature_matches_no_face_is_refused(tmp_path, capsys, measured):
    """Datum A's plane (QIF feature 2154, its face's surface at z=0) moved to z=3: no face of
    the STEP model lies there; the refusal names the feature, its plane and the STEP file."""
    root = ET.parse(qif("CTC-01")).getroot()
    face = next(f for f in root.iter(QIF3 + "Face") if f.get("id") == "494")
    surface = face.findtext(f"{QIF3}Surface/{QIF3}Id")
    plane = next(e for e in root.iter(QIF3 + "Plane23") if e.get("id") == surface)
    origin = plane.find(f"{QIF3}Plane23Core/{QIF3}Origin")
    x, y, _ = origin.text.split()
    origin.text = f"{x} {y} 3"
    ET.register_namespace("", QIF3[1:-1])
    moved = tmp_path / "moved.qif"
    ET.ElementTree(root).write(moved, encoding="utf-8", xml_declaration=True)
    err = _refused(capsys, stp("CTC-01"), measured, str(moved))
    assert "moved.qif" in err and "QIF feature 2154 (plane z=3)" in err
    assert "matches no face of nist_ctc_01_asme1_ap242-e1.stp within 0.093 mm" in err


@pytest.mark.parametrize("part", sorted(PARTS))
def test_orientation_zones_and_location_features_follow_the_qif(part):
    """An orientation is ``diametral`` exactly where its QIF definition's ZoneShape is a
    DiametricalZone; a position of OppositeParallelPlanes is a width's; one at MAXIMUM
    material condition is at MMC, with a size on each of its regions."""
    from engine.io.qif_plan import read_qif_plan

    plan = read_qif_plan(qif(part))
    root = ET.parse(qif(part)).getroot()
    index = {e.get("id"): e for e in root.iter() if e.get("id") is not None}
    features, _, _ = xml_geometry(qif(part))
    sized = {c.region for c in plan.characteristics if c.type == "size"}
    checked = 0
    for c in plan.characteristics:
        nominal = index[c.id.split(".")[0]]
        definition = index[nominal.findtext(QIF3 + "CharacteristicDefinitionId")]
        if c.type in ("parallelism", "perpendicularity", "angularity"):
            zone = definition.find(f"{QIF3}ZoneShape/{QIF3}DiametricalZone")
            assert c.diametral == (zone is not None), c
            checked += 1
        if c.type == "position":
            fid = nominal.find(f"{QIF3}FeatureNominalIds/{QIF3}Id").text
            if features[fid].tag == QIF3 + "OppositeParallelPlanesFeatureNominal":
                assert c.kind == "width", c
            condition = definition.findtext(QIF3 + "MaterialCondition")
            assert c.modifier == {"MAXIMUM": "MMC", "LEAST": "LMC"}.get(condition, "RFS")
            if c.modifier != "RFS":
                assert set(c.all_regions) <= sized
            checked += 1
    assert checked >= 3


def test_a_pmi_linear_unit_is_the_unit_of_the_characteristics_values(tmp_path):
    """QIF 3.0 (Units.xsd, PrimaryUnitsType): a ``PMILinearUnit`` overrides the primary linear
    unit for every value of the Characteristics. NIST FTC-06 (primary mm, PMI inch) gives its
    widths' targets and limits without a ``linearUnit``: read as mm, a perfect part's 12 in
    (304.8 mm) width was a confident REJECT against "12 ± 0.01 mm". Here CTC-01's file, its
    values' ``linearUnit="mm"`` removed and a PMI unit of inches declared: every length of
    every characteristic reads 25.4 times the original (its angle, in degrees, as before), the
    geometry (and the faces matched to it) as before."""
    from engine.io.qif_plan import qif_face_groups, read_qif_plan
    from engine.io.step import read_step

    text = Path(qif("CTC-01")).read_text("utf-8")
    assert text.count(' linearUnit="mm"') == 27
    head, tail = text.split("      </LinearUnit>\n", 1)
    pmi = ("      </LinearUnit>\n      <PMILinearUnit>\n        <SIUnitName>meter</SIUnitName>\n"
           "        <UnitName>inch</UnitName>\n        <UnitConversion>\n"
           "          <Factor>0.0254</Factor>\n        </UnitConversion>\n"
           "      </PMILinearUnit>\n")
    inch = tmp_path / "ctc01_pmi_inch.qif"
    inch.write_text((head + pmi + tail).replace(' linearUnit="mm"', ""), encoding="utf-8")
    a, b = read_qif_plan(qif("CTC-01")), read_qif_plan(inch)
    assert len(a.characteristics) == len(b.characteristics) == 14
    for x, y in zip(a.characteristics, b.characteristics):
        if x.type == "angle":  # 1491's 60° ±0.5°: degrees, no length (its PMIAngularUnit)
            assert (y.nominal, y.lower, y.upper) == (x.nominal, x.lower, x.upper) == (
                60.0, -0.5, 0.5)
            continue
        assert (y.lower, y.upper) == pytest.approx((25.4 * x.lower, 25.4 * x.upper), rel=1e-12)
        if x.nominal is not None:
            assert y.nominal == pytest.approx(25.4 * x.nominal, rel=1e-12)
    step = read_step(stp("CTC-01"))
    assert {k: list(v) for k, v in qif_face_groups(str(inch), step).items()} == \
        {k: list(v) for k, v in qif_face_groups(qif("CTC-01"), step).items()}


def test_a_characteristic_is_called_by_its_balloon_name_and_id():
    """Messages and the certificate name a characteristic by the drawing's balloon (the QIF
    Designator; the k-th part of a characteristic split per feature keeps its ".k"), with its
    name and id; one without a designator by its id, as before."""
    from engine.gdt.plan import Characteristic

    c = Characteristic("1479", "size", "qif:2175", -0.1, 0.05, nominal=20.0,
                       name="Linear Size.3", designator="3",
                       source="DiameterCharacteristicNominal 1479")
    assert c.balloon == "3"
    assert c.called == "characteristic 3 (size; Linear Size.3, id 1479)"
    split = Characteristic("1443.2", "position", "qif:2159", 0.0, 0.75, ("A",),
                           designator="14", source="PositionCharacteristicNominal 1443")
    assert split.balloon == "14.2" and split.called == "characteristic 14.2 (position; id 1443.2)"
    plain = Characteristic("p1", "flatness", "top", 0.0, 0.1)
    assert plain.balloon == "p1" and plain.called == "characteristic p1 (flatness)"
    named = Characteristic("p2", "flatness", "top", 0.0, 0.1, name="Flatness of the top")
    assert named.called == "characteristic p2 (flatness; Flatness of the top)"


def _mutated(tmp_path, *swaps, name="m.qif") -> str:
    """CTC-01's QIF with each (old, new) of ``swaps`` replaced (the first occurrence, or all
    when the third item is True)."""
    text = Path(qif("CTC-01")).read_text(encoding="utf-8")
    for old, new, *every in swaps:
        assert old in text, old
        text = text.replace(old, new) if every and every[0] else text.replace(old, new, 1)
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return str(path)


@pytest.mark.parametrize("swaps, says", [
    ([('<FlatnessCharacteristicNominal id="1470">', "<FlatnessCharacteristicNominal>")],
     "a FlatnessCharacteristicNominal (Flatness.1) has no id"),
    ([('<DiameterCharacteristicNominal id="1473">', '<DiameterCharacteristicNominal id="1470">')],
     "two characteristic nominals have the id 1470 (Flatness.1 and Linear Size.1)"),
    ([("<DatumLabel>B</DatumLabel>", "<DatumLabel>A</DatumLabel>")],
     "datum definitions 1432 and 1435 are both labelled A"),
    ([("<DatumLabel>B</DatumLabel>", "<DatumLabel></DatumLabel>")],
     "datum definition 1435 has no DatumLabel"),
    ([('<ToleranceValue linearUnit="mm">1.25</ToleranceValue>',
       '<ToleranceValue linearUnit="mm">1.25</ToleranceValue>'
       '<OuterDisposition linearUnit="mm">1e7</OuterDisposition>')],
     "characteristic 1457 (Position surfacic profile.3): tolerance zone 1e+07"),
])
def test_a_qif_plan_whose_ids_or_labels_do_not_name_one_item_is_refused(tmp_path, swaps, says):
    """A characteristic nominal without an id (its results could not name it: the certificate
    and `plan` ended in an internal error), two with one id, two datums with one label (the
    frames' A|A|C were judged), a datum without a label, a profile's limits 10 km off (exit 64
    before, the usage text, the file not named): refused, naming the file and the items."""
    from engine.errors import InputError
    from engine.io.qif_plan import read_qif_plan

    path = _mutated(tmp_path, *swaps)
    with pytest.raises(InputError, match=re.escape(f"{path}: {says}")):
        read_qif_plan(path)


def test_a_qif_plan_of_more_characteristics_than_a_plan_may_hold_is_refused(tmp_path):
    """The TOML plan's limit (engine.gdt.plan.MAX_CHARACTERISTICS) holds for a QIF's
    characteristic nominals too: 12,000 flatness nominals judged one by one for 17 s before."""
    from engine.errors import InputError
    from engine.gdt.plan import MAX_CHARACTERISTICS
    from engine.io.qif_plan import read_qif_plan

    e = xml_characteristics(qif("CTC-01"))[5]
    assert e.get("id") == "1470"
    text = Path(qif("CTC-01")).read_text(encoding="utf-8")
    start = text.index('<FlatnessCharacteristicNominal id="1470">')
    end = text.index("</FlatnessCharacteristicNominal>", start) + len(
        "</FlatnessCharacteristicNominal>")
    copies = "".join(text[start:end].replace('id="1470"', f'id="9{k:06d}"')
                     for k in range(MAX_CHARACTERISTICS))
    path = tmp_path / "many.qif"
    path.write_text(text[:end] + copies + text[end:], encoding="utf-8")
    with pytest.raises(InputError, match="holds 10,014 characteristics; a plan may hold at "
                                         "most 10,000"):
        read_qif_plan(str(path))


def test_a_hyphen_in_a_qif_datum_label_is_part_of_the_label(tmp_path):
    """"B-1" names datum B-1, not a common datum of B and 1 (the frames' checks split it and
    ended in an internal error): the plan reads, its frames name B-1."""
    from engine.io.qif_plan import read_qif_plan

    plan = read_qif_plan(_mutated(tmp_path, ("<DatumLabel>B</DatumLabel>",
                                             "<DatumLabel>B-1</DatumLabel>")))
    assert "B-1" in {d.label for d in plan.datums}
    frames = {c.datums for c in plan.characteristics if c.datums}
    assert ("A", "B-1", "C") in frames and not any("B" in f for f in frames)


@pytest.mark.parametrize("angle, unit, degrees", [("1.5707963267948966", "radian", 90.0),
                                                   ("90", "degree", 90.0),
                                                   ("0.25", "revolution", 90.0)])
def test_an_angularity_takes_its_angle_in_its_angular_unit(tmp_path, angle, unit, degrees):
    """CTC-01's perpendicularity 1467 written as an angularity at 90° in each unit the file
    declares: the angle is read in degrees (a radian was taken for degrees: 1.57°)."""
    from engine.io.qif_plan import read_qif_plan

    path = _mutated(tmp_path, ("PerpendicularityCharacteristic", "AngularityCharacteristic", True),
                    ("<Name>Perpendicularity.1</Name>",
                     f'<Name>Angularity.1</Name><Angle angularUnit="{unit}">{angle}</Angle>'))
    c = next(c for c in read_qif_plan(path).characteristics if c.id == "1467")
    assert c.type == "angularity" and c.angle == pytest.approx(degrees, abs=1e-9)


@pytest.mark.parametrize("factor, unit", [("0.001", "0"), ("0.001", "-0.001"),
                                          ("0.017453292519943", "0")])
def test_a_unit_whose_factor_is_not_positive_is_refused_naming_the_unit(tmp_path, factor, unit):
    """A linear unit of factor 0 was refused later for "feature 2154 (plane z=0) matches no
    face", one of -0.001 for a negative ToleranceValue, and an angle unit of 0 was read."""
    from engine.errors import InputError
    from engine.io.qif_plan import read_qif_plan

    path = _mutated(tmp_path, (f"<Factor>{factor}</Factor>", f"<Factor>{unit}</Factor>"))
    with pytest.raises(InputError, match=re.escape(
            f"its UnitConversion Factor is '{unit}'; a unit's factor must be > 0")):
        read_qif_plan(path)


def test_an_angularity_in_a_unit_the_file_does_not_declare_is_refused(tmp_path):
    from engine.errors import InputError
    from engine.io.qif_plan import read_qif_plan

    path = _mutated(tmp_path, ("PerpendicularityCharacteristic", "AngularityCharacteristic", True),
                    ("<Name>Perpendicularity.1</Name>",
                     '<Name>Angularity.1</Name><Angle angularUnit="grad">100</Angle>'))
    with pytest.raises(InputError, match="characteristic 1467's Angle: angularUnit 'grad' is "
                                         "not one of the file's units"):
        read_qif_plan(path)
