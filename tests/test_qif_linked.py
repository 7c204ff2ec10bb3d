"""QIF in, QIF out (issue 25): with a QIF plan, the QIF results are the plan's own document
carried through, its ids unchanged, with items for what was measured and results that reference
the plan's characteristic and feature nominals (reports.qif.linked). Checked against the QIF
3.0 schema and, independently of the writer, against the plan file and the JSON results as the
standard library's ElementTree reads them."""

import json
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from qa_app.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "tests", "data")
XSD = os.path.join(DATA, "qif-3.0-xsd", "QIFDocument.xsd")
Q = "{http://qifstandards.org/xsd/qif3}"
PARTS = {"CTC-01": ("NISTmodels__nist_ctc_01_asme1_ap242.qif", "nist_ctc_01_asme1_ap242-e1.stp"),
         "FTC-08": ("NISTmodels__nist_ftc_08_asme1_ap242-1.qif",
                    "nist_ftc_08_asme1_ap242-e1.stp")}


def _paths(part):
    q, s = PARTS[part]
    return os.path.join(DATA, "qif", q), os.path.join(DATA, "step", s)


def _inspect(tmp_path, part, n, seed):
    """Points on the part's exact faces in a random pose, inspected with its QIF plan: (exit
    code, JSON results, the QIF results' root, the plan's root)."""
    from engine.io.step import read_step
    from step_models import random_pose
    from sweep import on_part

    plan, stp = _paths(part)
    rng = np.random.default_rng(seed)
    P, N, _ = on_part(read_step(stp), rng, n)
    P = P + rng.normal(0.0, 1e-4, len(P))[:, None] * N
    R, t = random_pose(seed)
    np.savetxt(tmp_path / "m.csv", P @ R.T + t, delimiter=",", header="x,y,z", comments="",
               fmt="%.9f")
    code = main(["inspect", stp, str(tmp_path / "m.csv"), "--plan", plan, "--quiet",
                 "--json", str(tmp_path / "r.json"), "--qif", str(tmp_path / "r.qif")])
    doc = json.loads((tmp_path / "r.json").read_text())
    return code, doc, ET.parse(tmp_path / "r.qif").getroot(), ET.parse(plan).getroot()


def _valid(path):
    from lxml import etree

    schema = etree.XMLSchema(etree.parse(XSD))
    ok = schema.validate(etree.parse(str(path)))
    assert ok, [e.message for e in list(schema.error_log)[:5]]


def _by_id(root):
    return {e.get("id"): e for e in root.iter() if e.get("id") is not None}


def _measurements(root):
    return root.findall(f"{Q}Results/{Q}MeasurementResultsSet/{Q}MeasurementResults/"
                        f"{Q}MeasuredCharacteristics/{Q}CharacteristicMeasurements/*")


def _local(e) -> str:
    return e.tag[len(Q):]


def _answers(out, ids):
    """{plan characteristic nominal id: [(measurement, item, [feature nominal ids])]}."""
    found: dict = {}
    for m in _measurements(out):
        item = ids[m.findtext(f"{Q}CharacteristicItemId").strip()]
        nominal = item.findtext(f"{Q}CharacteristicNominalId").strip()
        features = []
        for i in m.iterfind(f"{Q}FeatureMeasurementIds/{Q}Id"):
            fm = ids[i.text.strip()]
            fi = ids[fm.findtext(f"{Q}FeatureItemId").strip()]
            assert _local(fm)[:-len("Measurement")] == _local(fi)[:-len("Item")]
            features.append(fi.findtext(f"{Q}FeatureNominalId").strip())
        found.setdefault(nominal, []).append((m, item, features))
    return found


def test_a_qif_plans_results_are_its_own_document_answered(tmp_path):
    """CTC-01 (mm) with its QIF plan, every characteristic judged. The results validate; every
    element of the plan with an id is in them, the same element under the same id; the ids
    added follow the plan's idMax and none repeats; each characteristic judged has one
    measurement of the plan's kind, through an item naming the plan's nominal, on the plan's
    features, with the JSON's verdict and value; a plane's feature measurement is the JSON's
    fitted plane."""
    code, doc, out, plan = _inspect(tmp_path, "CTC-01", 12000, 7)
    _valid(tmp_path / "r.qif")
    ids, plan_ids = _by_id(out), _by_id(plan)
    every = [e.get("id") for e in out.iter() if e.get("id") is not None]
    assert len(every) == len(set(every))
    assert int(out.get("idMax")) == max(int(i) for i in every)
    added = set(every) - set(plan_ids)
    assert min(int(i) for i in added) > int(plan.get("idMax"))
    for i, e in plan_ids.items():
        if _local(e) in ("Results", "MeasurementResults"):
            continue
        assert i in ids and ids[i].tag == e.tag, i
    assert ids["2159"].findtext(f"{Q}Name") == plan_ids["2159"].findtext(f"{Q}Name")
    status = {"ACCEPT": "PASS", "REJECT": "FAIL", "INCONCLUSIVE": "INDETERMINATE"}
    answers = _answers(out, ids)
    assert len(doc["characteristics"]) == 14 and len(answers) == 14
    for c in doc["characteristics"]:
        (m, item, features), = answers[c["id"]]
        nominal = plan_ids[c["id"]]
        assert _local(m) == _local(nominal).replace("Nominal", "Measurement")
        assert _local(item) == _local(nominal).replace("Nominal", "Item")
        assert m.findtext(f"{Q}Status/{Q}CharacteristicStatusEnum") == status[c["verdict"]]
        assert float(m.findtext(f"{Q}Value")) == pytest.approx(c["value"], abs=1e-6)
        qif_features = {t.partition("/")[0] for t in c["region"][4:].split("+")}
        assert set(features) == qif_features, c["id"]
        assert item.findtext(f"{Q}CharacteristicDesignator/{Q}Designator") == c["designator"]
    plane = next(f for f in doc["features"] if f["region"] == "qif:2154")
    (fm,) = [e for e in out.iter(f"{Q}PlaneFeatureMeasurement")
             if ids[e.findtext(f"{Q}FeatureItemId").strip()].findtext(
                 f"{Q}FeatureNominalId").strip() == "2154"]
    location = [float(v) for v in fm.findtext(f"{Q}Location").split()]
    assert location == pytest.approx(plane["measured"]["point"], abs=1e-6)
    assert code == {"ACCEPT": 0, "REJECT": 1}[doc["verdict"]]


def test_an_inch_plans_results_are_in_inches_and_name_what_was_not_judged(tmp_path):
    """FTC-08 is in inches, its geometry drawn at twice its size (ScaleCoefficient 2): the
    characteristics' values are the JSON's mm over 25.4, the measured points the registered
    ones in the geometry's units (mm / 25.4 x 2, as the plan's features are); its 5
    characteristics not judged are each answered INDETERMINATE with their reason, so that every
    characteristic of the plan has its answer."""
    _, doc, out, plan = _inspect(tmp_path, "FTC-08", 12000, 3)
    _valid(tmp_path / "r.qif")
    ids = _by_id(out)
    answers = _answers(out, ids)
    nominals = plan.findall(f"{Q}Characteristics/{Q}CharacteristicNominals/*")
    assert set(answers) == {e.get("id") for e in nominals}
    judged: dict = {}
    for c in doc["characteristics"]:
        judged.setdefault(c["id"].split(".")[0], []).append(c)
    for nid, cs in judged.items():
        got = sorted(float(m.findtext(f"{Q}Value")) for m, _, _ in answers[nid]
                     if m.find(f"{Q}Value") is not None)
        want = sorted(c["value"] / 25.4 for c in cs if c["value"] is not None)
        assert got == pytest.approx(want, abs=1e-6), nid
    not_judged = doc["plan_faces"]["not_judged"]
    assert len(not_judged) == 5
    for n in not_judged:
        (m, _, _), = answers[n["id"]]
        assert m.findtext(f"{Q}Status/{Q}CharacteristicStatusEnum") == "INDETERMINATE"
        assert m.find(f"{Q}Value") is None
        assert n["reason"] in m.findtext(f"{Q}Description")
    ps = out.find(f".//{Q}MeasuredPointSet")
    pts = np.array(ps.findtext(f"{Q}Points").split(), float).reshape(-1, 3)
    csv = np.loadtxt(tmp_path / "m.csv", delimiter=",", skiprows=1)
    assert pts.shape == csv.shape
    scale = float(plan.findtext(f"{Q}Product/{Q}Header/{Q}ScaleCoefficient"))
    assert scale == 2.0
    assert out.findtext(f"{Q}Header/{Q}Description").endswith(
        "(positive = excess material), inch x 2 (the plan's scale)")
    T = np.array(doc["alignment"]["T_nominal_measured"])
    assert np.allclose(pts * 25.4 / scale, csv @ T[:3, :3].T + T[:3, 3], atol=1e-4)


def test_a_qif_plan_changed_since_it_was_inspected_is_not_answered(tmp_path):
    """The results reference the plan judged: one read again with other bytes (another
    revision saved over it) is refused, naming the file, rather than answered."""
    import hashlib
    from pathlib import Path

    from engine.errors import InputError
    from engine.io.qif_plan import qif_source

    plan, _ = _paths("CTC-01")
    copy = tmp_path / "plan.qif"
    data = Path(plan).read_bytes()
    copy.write_bytes(data)
    sha = hashlib.sha256(data).hexdigest()
    assert qif_source(copy, sha).units.unit == "mm"
    copy.write_bytes(data.replace(b"<Name>Position.1</Name>", b"<Name>Position.9</Name>"))
    with pytest.raises(InputError, match="changed since it was inspected") as e:
        qif_source(copy, sha)
    assert "plan.qif" in str(e.value)


def test_a_qif_plan_with_its_own_items_is_answered_through_them(tmp_path):
    """A QIF Plan (the official simplePlan sample, tests/data/qif) states its own items and
    names a characteristic's features through them only. Judged here, on a JSON made from the
    seat bracket sample's: the diameter 38 on its feature 35 (answered through the plan's item
    39), the position 45 on each of its features 35 and 49 (two new items: the plan's one is
    for one feature), the position 59 on feature 62 (a new item: the plan's lists feature 49);
    the other 8 are not judged. Every characteristic is answered; each one not judged on the
    features of its plan item (not on the whole part); a linear coordinate's measurement states
    its coordinates UNDEFINED, as the schema requires it to state some."""
    import copy
    import hashlib
    from pathlib import Path

    from engine.io.qif_plan import qif_source
    from engine.pipeline import inspection_settings, run_files
    from reports.qif import qif_results_document
    from reports.results import run_document

    samples = os.path.join(ROOT, "samples", "seat_bracket")
    run = run_files(os.path.join(samples, "nominal.xyz"), os.path.join(samples, "measured.csv"),
                    inspection_settings(None, os.path.join(samples, "plan.toml")))
    doc = run_document(run)
    by_type = {c["type"]: c for c in doc["characteristics"]}
    source = "Plans__simplePlan.QIF"

    def judged(template, cid, region, nominal_kind):
        c = copy.deepcopy(by_type[template])
        c.update(id=cid, region=region, verdict="ACCEPT", designator=None,
                 source={"file": source, "item": f"{nominal_kind} {cid.split('.')[0]}"})
        return c

    doc["characteristics"] = [
        judged("size", "38", "qif:35", "DiameterCharacteristicNominal"),
        judged("position", "45.1", "qif:35", "PositionCharacteristicNominal"),
        judged("position", "45.2", "qif:49", "PositionCharacteristicNominal"),
        judged("position", "59", "qif:62", "PositionCharacteristicNominal")]
    doc["features"] = []
    left = ("13", "20", "23", "26", "32", "52", "65", "68")
    doc["plan_faces"] = {"not_judged": [{"id": i, "type": "t", "name": f"c{i}",
                                         "reason": f"reason {i}"} for i in left]}
    path = os.path.join(DATA, "qif", source)
    plan = qif_source(path, hashlib.sha256(Path(path).read_bytes()).hexdigest())
    res = run.result
    (tmp_path / "r.qif").write_bytes(qif_results_document(
        doc, res.registered, res.deviations.signed, res.in_tolerance, None, None, plan))
    _valid(tmp_path / "r.qif")
    out, given = ET.parse(tmp_path / "r.qif").getroot(), ET.parse(path).getroot()
    ids = _by_id(out)
    answers = _answers(out, ids)
    nominals = given.findall(f"{Q}Characteristics/{Q}CharacteristicNominals/*")
    assert set(answers) == {e.get("id") for e in nominals} and len(nominals) == 11
    idmax = int(given.get("idMax"))

    def plan_item_features(nid):
        item = next(e for e in given.iter() if e.tag.endswith("CharacteristicItem")
                    and e.findtext(f"{Q}CharacteristicNominalId") == nid)
        fitems = {e.get("id"): e.findtext(f"{Q}FeatureNominalId") for e in given.iter()
                  if e.tag.endswith("FeatureItem")}
        return item.get("id"), [fitems[i.text] for i in item.iterfind(f"{Q}FeatureItemIds/{Q}Id")
                                if i.text in fitems]

    (m, item, features), = answers["38"]
    assert (item.get("id"), features) == ("39", ["35"]) == plan_item_features("38")
    assert sorted((f, int(i.get("id")) > idmax) for _, i, f in answers["45"]) == \
        [(["35"], True), (["49"], True)]
    (m, item, features), = answers["59"]
    assert features == ["62"] and int(item.get("id")) > idmax
    for nid in left:
        (m, item, features), = answers[nid]
        assert m.findtext(f"{Q}Status/{Q}CharacteristicStatusEnum") == "INDETERMINATE"
        assert f"reason {nid}" in m.findtext(f"{Q}Description")
        assert (item.get("id"), features) == plan_item_features(nid), nid
        if _local(m).startswith("LinearCoordinate"):
            assert m.findtext(f"{Q}TypeOfCoordinates/{Q}CoordinateEnum") == "UNDEFINED"
