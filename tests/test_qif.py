"""QIF 3.0 results export: valid against the official schemas, faithful to the inspection (points,
deviations, zone, status), deterministic.

The documents come from real inspections of the bundled samples through the command line; the
JSON and CSV it writes are read back as the inputs, and the QIF is checked against them with an
independent parser (lxml), not with reports.qif's own code.
"""

import copy
import csv
import json
import os

import numpy as np
import pytest
from lxml import etree

from qa_app.cli import main
from reports.qif import qif_results_document

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
XSD = os.path.join(ROOT, "tests", "data", "qif-3.0-xsd", "QIFDocument.xsd")
# Loading the schema set (20 files) once for the whole module.
SCHEMA = etree.XMLSchema(etree.parse(XSD))
NS = {"q": "http://qifstandards.org/xsd/qif3"}
STATUS = {"ACCEPT": ("PASS", "PASS"), "REJECT": ("FAIL", "FAIL"),
          "INCONCLUSIVE": ("INDETERMINATE", "UNKNOWN")}

BELLY = ("samples/belly_fairing/nominal.csv", "samples/belly_fairing/measured.csv")
FRAME = ("samples/fuselage_frame/template.dxf", "samples/fuselage_frame/measured.csv")
# The belly fairing's points measured against the seat bracket: not this part, no trusted pose.
WRONG_PART = ("samples/seat_bracket/nominal.xyz", "samples/belly_fairing/measured.csv")
CASES = {
    "accept": (BELLY, ["--tol", "0.25"]),
    "reject": (BELLY, ["--tol", "0.05"]),
    "inconclusive": (WRONG_PART, ["--tol", "0.05"]),
    "template": (FRAME, ["--tol", "0.05"]),
    "asymmetric": (FRAME, ["--tol-lower", "-0.1", "--tol-upper", "0.3"]),
}
CERTIFICATE = {"number": "QA-2024-0042", "part_number": "D52-1100-7",
               "part_name": "Belly fairing", "serial": "SN 0815 & <7>", "revision": "C",
               "order": "PO-77", "inspector": "A. Inspector", "organisation": "ACME Aero QA",
               "device": "Laser tracker LT-3", "issued": "2024-05-01T12:30:00+02:00"}


class Inspection:
    """One command-line inspection read back: the JSON document and the CSV's per-point columns."""

    def __init__(self, d, files, args):
        nominal, measured = (os.path.join(ROOT, f) for f in files)
        self.csv = d / "r.csv"
        self.code = main(["inspect", nominal, measured, *args, "--json", str(d / "r.json"),
                          "--csv", str(d / "r.csv")])
        with open(d / "r.json") as f:
            self.doc = json.load(f)
        with open(d / "r.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        self.registered = np.array([[float(r[k]) for k in ("x_reg", "y_reg", "z_reg")]
                                    for r in rows])
        self.deviations = np.array([float(r["deviation"]) for r in rows])
        self.inside = np.array([r["in_tolerance"] == "true" for r in rows])
        self.labels = np.array([r["label"] for r in rows])

    def qif(self, doc=None, **kw) -> bytes:
        return qif_results_document(self.doc if doc is None else doc, self.registered,
                                    self.deviations, self.inside, self.labels, **kw)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = {}
    for name, (files, args) in CASES.items():
        out[name] = Inspection(tmp_path_factory.mktemp(name), files, args)
    return out


def parse_valid(data: bytes):
    tree = etree.ElementTree(etree.fromstring(data))
    assert SCHEMA.validate(tree), "\n".join(str(e) for e in SCHEMA.error_log)
    return tree.getroot()


def one(root, path):
    found = root.xpath(path, namespaces=NS)
    assert len(found) == 1, (path, len(found))
    return found[0]


def numbers(el):
    return np.array([float(v) for v in el.text.split()])


def attribute(point_set, name):
    return one(point_set, f"q:Attributes/q:AttributeStr[@name='{name}']").get("value")


@pytest.mark.parametrize("case, verdict", [("accept", "ACCEPT"), ("reject", "REJECT"),
                                           ("inconclusive", "INCONCLUSIVE"),
                                           ("template", "ACCEPT")])
def test_valid_and_faithful(runs, case, verdict):
    run = runs[case]
    assert run.doc["verdict"] == verdict and run.code == {"ACCEPT": 0, "REJECT": 1,
                                                          "INCONCLUSIVE": 2}[verdict]
    root = parse_valid(run.qif())
    assert root.get("versionQIF") == "3.0.0"
    n = run.deviations.size
    assert n == run.doc["deviations"]["count"] > 0

    ps = one(root, "//q:MeasurementResults/q:MeasuredPointSets/q:MeasuredPointSet")
    assert int(ps.get("count")) == n
    pts = numbers(one(ps, "q:Points")).reshape(-1, 3)
    dev = numbers(one(ps, "q:Deviations"))
    assert pts.shape == (n, 3) and dev.shape == (n,)
    np.testing.assert_allclose(pts, run.registered, rtol=0, atol=1e-6)
    np.testing.assert_allclose(dev, run.deviations, rtol=0, atol=1e-6)
    flags = attribute(ps, "qa-inspect:in-tolerance")
    assert flags == "".join("1" if v else "0" for v in run.inside)
    assert json.loads(attribute(ps, "qa-inspect:labels")) == list(run.labels)

    char_status, inspection_status = STATUS[verdict]
    profile = "LineProfile" if case == "template" else "SurfaceProfile"
    meas = one(root, f"//q:MeasuredCharacteristics//q:{profile}CharacteristicMeasurement")
    assert one(meas, "q:Status/q:CharacteristicStatusEnum").text == char_status
    assert one(root, "//q:MeasurementResults/q:InspectionStatus/q:InspectionStatusEnum").text \
        == inspection_status
    assert float(one(meas, "q:WorstPositiveDeviation").text) == pytest.approx(
        run.deviations.max(), abs=1e-6)
    assert float(one(meas, "q:WorstNegativeDeviation").text) == pytest.approx(
        run.deviations.min(), abs=1e-6)

    # The measurement chain resolves: characteristic -> feature measurement -> this point set.
    fm_id = one(meas, "q:FeatureMeasurementIds/q:Id").text
    fm = one(root, f"//q:MeasuredFeatures/*[@id='{fm_id}']")
    assert one(fm, "q:PointList/q:WholePointSetId").text == ps.get("id")
    assert fm.tag.endswith("OtherCurveFeatureMeasurement" if case == "template"
                           else "OtherSurfaceFeatureMeasurement")
    ids = [int(v) for v in root.xpath("//@id")]
    assert len(ids) == len(set(ids)) and int(root.get("idMax")) == max(ids)


def test_symmetric_zone_and_value(runs):
    run = runs["reject"]
    root = parse_valid(run.qif())
    definition = one(root, "//q:SurfaceProfileCharacteristicDefinition")
    assert float(one(definition, "q:ToleranceValue").text) == pytest.approx(0.1, abs=1e-9)
    assert not definition.xpath("q:OuterDisposition", namespaces=NS)
    value = float(one(root, "//q:SurfaceProfileCharacteristicMeasurement/q:Value").text)
    assert value == pytest.approx(2 * np.abs(run.deviations).max(), abs=2e-6)
    assert value > 0.1  # REJECT: the points need a wider zone than the tolerance


def test_asymmetric_zone_round_trips(runs):
    run = runs["asymmetric"]
    assert (run.doc["tolerance"]["lower"], run.doc["tolerance"]["upper"]) == (-0.1, 0.3)
    root = parse_valid(run.qif())
    definition = one(root, "//q:LineProfileCharacteristicDefinition")
    width = float(one(definition, "q:ToleranceValue").text)
    upper = float(one(definition, "q:OuterDisposition").text)
    assert upper == pytest.approx(0.3, abs=1e-9)
    assert upper - width == pytest.approx(-0.1, abs=1e-9)
    assert one(root, "//q:LineProfileCharacteristicNominal/q:Vector").text.split() == \
        ["0", "0", "1"]
    # Value is the width of the smallest zone centred like [-0.1, 0.3] that holds every point.
    value = float(one(root, "//q:LineProfileCharacteristicMeasurement/q:Value").text)
    assert value == pytest.approx(2 * np.abs(run.deviations - 0.1).max(), abs=2e-6)
    assert (value <= width) == (run.doc["verdict"] == "ACCEPT")


def test_certificate_traceability(runs):
    run = runs["accept"]
    doc = dict(run.doc, certificate=CERTIFICATE)
    root = parse_valid(run.qif(doc))
    mr = one(root, "//q:MeasurementResults")
    assert one(mr, "q:InspectionTraceability/q:ReportNumber").text == "QA-2024-0042"
    assert one(mr, "q:InspectionTraceability/q:OrderNumber").text == "PO-77"
    assert one(mr, "q:InspectionTraceability/q:InspectionOperator/q:Name").text == "A. Inspector"
    assert one(mr, "q:InspectionTraceability/q:InspectingOrganization/q:Name").text == \
        "ACME Aero QA"
    assert one(mr, "q:InspectionTraceability/q:ReportPreparationDate").text == \
        "2024-05-01T10:30:00Z"
    part = one(root, "//q:Product/q:PartSet/q:Part")
    assert one(part, "q:ModelNumber").text == "D52-1100-7"
    assert one(part, "q:Header/q:Name").text == "Belly fairing"
    assert one(part, "q:Version").text == "C"
    assert one(part, "q:DefinitionExternal/q:DigitalModel/q:Name").text == "nominal.csv"
    serial = one(root, "//q:ActualComponentSets//q:ActualComponent")
    assert one(serial, "q:SerialNumber").text == "SN 0815 & <7>"
    assert one(mr, "q:ActualComponentIds/q:Id").text == serial.get("id")
    device = one(root, "//q:MeasurementResources//q:MeasurementDevice")
    assert one(device, "q:Name").text == "Laser tracker LT-3"
    assert one(mr, "q:MeasuredPointSets/q:MeasuredPointSet/q:MeasurementDeviceId").text == \
        device.get("id")
    assert one(root, "q:Header/q:Application/q:Name").text.startswith("qa-inspect ")
    # No device named: no MeasurementResources at all.
    bare = dict(run.doc, certificate={"number": "X-1", "device": None})
    assert not parse_valid(run.qif(bare)).xpath("//q:MeasurementResources", namespaces=NS)


def test_certificate_traceability_fields(runs):
    """The device's serial, calibration date and probe on the MeasurementDevice; the part's
    temperature and the measurement program on the results' traceability; the drawing on the
    part and the CAD revision as the nominal model's file version; valid QIF 3.0."""
    run = runs["accept"]
    cert = dict(CERTIFICATE, device_serial="C-4711", calibration_date="2025-03-01",
                probe="VAST XT, 3 mm ruby", temperature_c=21.5, program="BF-1100.mpp",
                drawing="D52-1100", cad_revision="7.2")
    root = parse_valid(run.qif(dict(run.doc, certificate=cert)))
    device = one(root, "//q:MeasurementResources//q:MeasurementDevice")
    assert one(device, "q:SerialNumber").text == "C-4711"
    assert attribute(device, "qa-inspect:probe") == "VAST XT, 3 mm ruby"
    assert attribute(device, "qa-inspect:calibration-date") == "2025-03-01"
    trace = one(root, "//q:MeasurementResults/q:InspectionTraceability")
    assert float(one(trace, "q:Attributes/q:AttributeD1[@name='qa-inspect:temperature-c']")
                 .get("value")) == 21.5
    assert attribute(trace, "qa-inspect:measurement-program") == "BF-1100.mpp"
    part = one(root, "//q:Product/q:PartSet/q:Part")
    assert attribute(part, "qa-inspect:drawing") == "D52-1100"
    assert one(part, "q:DefinitionExternal/q:DigitalModel/q:File/q:Version").text == "7.2"
    # A serial number alone still names a device (its name then says only that).
    bare = dict(run.doc, certificate={"number": "X-1", "device_serial": "C-4711"})
    device = one(parse_valid(run.qif(bare)), "//q:MeasurementResources//q:MeasurementDevice")
    assert one(device, "q:Name").text == "measuring device"


def test_deterministic(runs):
    run = runs["template"]
    doc = dict(run.doc, certificate=CERTIFICATE)
    first = run.qif(copy.deepcopy(doc), outlier=run.deviations > 0.02)
    assert run.qif(copy.deepcopy(doc), outlier=run.deviations > 0.02) == first
    other = run.qif(dict(doc, certificate=dict(CERTIFICATE, number="QA-2024-0043")),
                    outlier=run.deviations > 0.02)
    qpid = "q:QPId"
    assert one(etree.fromstring(other), qpid).text != one(etree.fromstring(first), qpid).text
    ps = one(parse_valid(first), "//q:MeasuredPointSet")
    assert attribute(ps, "qa-inspect:excluded-from-alignment") == "".join(
        "1" if v else "0" for v in run.deviations > 0.02)


def test_schema_checks_references(runs):
    """The validation is worth something: a dangling reference is caught (key/keyref)."""
    root = etree.fromstring(runs["accept"].qif())
    one(root, "//q:SurfaceProfileCharacteristicMeasurement/q:CharacteristicItemId").text = "9999"
    assert not SCHEMA.validate(etree.ElementTree(root))


def test_full_precision_inputs_and_non_finite(runs):
    """Unrounded arrays come back within half a nanometre; NaN stays a valid xs:double."""
    rng = np.random.default_rng(7)
    n = 5000
    pts = rng.uniform(-2000, 2000, (n, 3))
    dev = rng.normal(0, 0.1, n)
    dev[17] = np.nan
    doc = copy.deepcopy(runs["accept"].doc)
    root = parse_valid(qif_results_document(doc, pts, dev, np.abs(dev) <= 0.25))
    ps = one(root, "//q:MeasuredPointSet")
    np.testing.assert_allclose(numbers(one(ps, "q:Points")).reshape(-1, 3), pts, rtol=0,
                               atol=5e-7 + 1e-9)
    back = numbers(one(ps, "q:Deviations"))
    assert np.isnan(back[17]) and np.isnan(back).sum() == 1
    finite = np.isfinite(dev)
    np.testing.assert_allclose(back[finite], dev[finite], rtol=0, atol=5e-7 + 1e-12)
    assert ps.xpath("q:Attributes/q:AttributeStr[@name='qa-inspect:labels']",
                    namespaces=NS) == []


def test_arguments_that_do_not_fit_are_errors_of_the_product(runs):
    """Per-point arrays of another length, an unknown verdict or an issue time that is no time:
    a QAError (also a ValueError, as before) naming the problem, and no document."""
    from engine.errors import QAError

    run = runs["accept"]
    n = len(run.deviations)
    cases = [
        (lambda: qif_results_document(run.doc, run.registered[:, :1], run.deviations,
                                      run.inside), r"registered must be \(n, 3\)"),
        (lambda: qif_results_document(run.doc, run.registered, run.deviations[1:], run.inside),
         f"deviations has {n - 1} entries for {n} points"),
        (lambda: qif_results_document(run.doc, run.registered, run.deviations, run.inside[:3]),
         f"in_tolerance has 3 entries for {n} points"),
        (lambda: run.qif(outlier=np.zeros(n + 1, bool)), f"outlier has {n + 1} entries"),
        (lambda: qif_results_document(run.doc, run.registered, run.deviations, run.inside,
                                      ["a"]), f"labels has 1 entries for {n} points"),
        (lambda: run.qif(dict(run.doc, verdict="PASSED")), "unknown verdict 'PASSED'"),
        (lambda: run.qif(dict(run.doc, certificate={"issued": "yesterday"})),
         "certificate 'issued' is not an ISO 8601 time: 'yesterday'"),
    ]
    for make, message in cases:
        with pytest.raises(QAError, match=message) as caught:
            make()
        assert isinstance(caught.value, ValueError)


# ---------------------------------------------------------------------------- inspection plans
SEAT = ("samples/seat_bracket/nominal.xyz", "samples/seat_bracket/measured.csv")
SEAT_PLAN = os.path.join(ROOT, "samples", "seat_bracket", "plan.toml")
QIF_TYPE = {"profile": "SurfaceProfile", "flatness": "Flatness", "position": "Position",
            "size": "Diameter"}


@pytest.fixture(scope="module")
def plan_run(tmp_path_factory):
    """The seat bracket judged by its plan (REJECT: the skin's profile to A|B|C), with its
    certificate (an unsigned draft) written the way a user writes it."""
    d = tmp_path_factory.mktemp("plan")
    run = Inspection(d, SEAT, ["--plan", SEAT_PLAN, "--report", str(d / "r.pdf")])
    run.pdf = d / "r.pdf"
    with open(os.path.join(ROOT, "samples", "seat_bracket", "truth.json")) as f:
        run.truth = json.load(f)
    return run


def by_id(root, i):
    return one(root, f"//*[@id='{i}']")


def local(el) -> str:
    return etree.QName(el).localname


def characteristic(root, cid):
    """(item, definition, nominal, measurement) of the characteristic whose balloon is cid."""
    item = one(root, "//q:CharacteristicItems/*[q:CharacteristicDesignator/q:Designator="
                     f"'{cid}']")
    nominal = by_id(root, one(item, "q:CharacteristicNominalId").text)
    definition = by_id(root, one(nominal, "q:CharacteristicDefinitionId").text)
    measurement = one(root, "//q:CharacteristicMeasurements/*[q:CharacteristicItemId="
                            f"'{item.get('id')}']")
    return item, definition, nominal, measurement


def value(el, path):
    return float(one(el, path).text)


def test_plan_characteristics_are_the_jsons(plan_run):
    """One characteristic (definition, nominal, item, measurement) per plan characteristic, of
    the QIF type its kind names, with the JSON's zone, value and verdict, on its region's
    feature; the inspection's status is the plan's."""
    run = plan_run
    assert run.code == 1 and run.doc["verdict"] == "REJECT"
    root = parse_valid(run.qif())
    chars = run.doc["characteristics"]
    assert [c["id"] for c in chars] == ["1", "2", "3", "4", "5"]
    for tag in ("CharacteristicDefinitions", "CharacteristicNominals", "CharacteristicItems",
                "CharacteristicMeasurements"):
        assert len(one(root, f"//q:{tag}")) == len(chars), tag
    for c in chars:
        item, definition, nominal, meas = characteristic(root, c["id"])
        kind = QIF_TYPE[c["type"]]
        assert [local(e) for e in (definition, nominal, item, meas)] == [
            f"{kind}Characteristic{s}" for s in ("Definition", "Nominal", "Item", "Measurement")]
        assert one(meas, "q:Status/q:CharacteristicStatusEnum").text == STATUS[c["verdict"]][0]
        assert value(meas, "q:Value") == pytest.approx(c["value"], abs=1e-6)
        if c["type"] == "size":
            assert value(nominal, "q:TargetValue") == pytest.approx(c["nominal"], abs=1e-9)
            assert value(definition, "q:Tolerance/q:MaxValue") == pytest.approx(c["upper"])
            assert value(definition, "q:Tolerance/q:MinValue") == pytest.approx(c["lower"])
        else:
            assert value(definition, "q:ToleranceValue") == pytest.approx(c["zone"], abs=1e-9)
        # The chain resolves to the region's feature: item -> feature item (named after the
        # region) <- feature measurement <- characteristic measurement.
        feature_item = by_id(root, one(item, "q:FeatureItemIds/q:Id").text)
        assert one(feature_item, "q:FeatureName").text == c["region"]
        fm = by_id(root, one(meas, "q:FeatureMeasurementIds/q:Id").text)
        assert one(fm, "q:FeatureItemId").text == feature_item.get("id")
        assert one(nominal, "q:FeatureNominalIds/q:Id").text == \
            one(feature_item, "q:FeatureNominalId").text
    assert one(root, "//q:InspectionStatus/q:InspectionStatusEnum").text == "FAIL"
    # The plan replaces the profile over all points: no other characteristic.
    assert len(root.xpath("//q:CharacteristicItems/*", namespaces=NS)) == 5
    ids = [int(v) for v in root.xpath("//@id")]
    assert len(ids) == len(set(ids)) and int(root.get("idMax")) == max(ids)


def test_plan_datum_reference_frame_and_datum_features(plan_run):
    """Profile 1 and position 4 refer to one DatumReferenceFrame: datums A, B, C in this
    precedence, each a tangent plane (ONESIDED) on its datum feature, whose nominal and
    measured planes are the sample's faces (truth.json)."""
    run, truth = plan_run, plan_run.truth
    root = parse_valid(run.qif())
    frames = {characteristic(root, cid)[1].xpath("string(q:DatumReferenceFrameId)",
                                                 namespaces=NS) for cid in "12345"}
    assert len(frames - {""}) == 1 and len(frames) == 2  # A|B|C, and form-only / size
    for cid, framed in zip("12345", (True, False, False, True, False)):
        assert bool(characteristic(root, cid)[1].xpath("q:DatumReferenceFrameId",
                                                       namespaces=NS)) == framed, cid
    drf = by_id(root, (frames - {""}).pop())
    assert local(drf) == "DatumReferenceFrame"
    datums = drf.xpath("q:Datums/q:Datum", namespaces=NS)
    assert [one(d, "q:Precedence/q:PrecedenceEnum").text for d in datums] == [
        "PRIMARY", "SECONDARY", "TERTIARY"]
    definitions = [by_id(root, one(d, "q:SimpleDatum/q:DatumDefinitionId").text)
                   for d in datums]
    assert [one(d, "q:DatumLabel").text for d in definitions] == ["A", "B", "C"]
    assert [one(d, "q:SimpleDatum//q:SubstituteFeatureAlgorithmEnum").text
            for d in datums] == ["ONESIDED"] * 3
    for label, definition in zip("ABC", definitions):
        face = truth["datum_faces"][label]
        n_true = np.array(face["outward_normal"])
        nominal = by_id(root, one(definition, "q:FeatureNominalIds/q:Id").text)
        assert local(nominal) == "PlaneFeatureNominal"
        assert numbers(one(nominal, "q:Normal")) @ n_true == pytest.approx(1.0, abs=1e-6)
        assert abs(numbers(one(nominal, "q:Location")) @ n_true) < 1e-3  # z, x, y = 0
        item = one(root, f"//q:FeatureItems/*[q:FeatureNominalId='{nominal.get('id')}']")
        meas = one(root, f"//q:MeasuredFeatures/*[q:FeatureItemId='{item.get('id')}']")
        assert local(meas) == "PlaneFeatureMeasurement"
        # Machined true (noise 1.5 um), placed by the tangent datums at their nominal planes.
        assert numbers(one(meas, "q:Normal")) @ n_true == pytest.approx(1.0, abs=1e-6)
        assert abs(numbers(one(meas, "q:Location")) @ n_true) < 0.005
        assert value(meas, "q:Form") < 6 * 0.0015
    # Flatness 3 is on datum A's feature.
    flat_item = characteristic(root, "3")[0]
    assert one(by_id(root, one(flat_item, "q:FeatureItemIds/q:Id").text),
               "q:FeatureNominalId").text == one(definitions[0], "q:FeatureNominalIds/q:Id").text


def test_plan_hole_is_a_cylinder_feature(plan_run):
    """Position 4 and size 5 are on one internal cylinder: nominal axis and diameter as drawn,
    measured as made (truth.json) and the measured diameter is the size's value."""
    run, hole = plan_run, plan_run.truth["hole"]
    root = parse_valid(run.qif())
    items = {one(characteristic(root, cid)[0], "q:FeatureItemIds/q:Id").text for cid in "45"}
    assert len(items) == 1
    item = by_id(root, items.pop())
    assert local(item) == "CylinderFeatureItem"
    nominal = by_id(root, one(item, "q:FeatureNominalId").text)
    definition = by_id(root, one(nominal, "q:FeatureDefinitionId").text)
    assert one(definition, "q:InternalExternal").text == "INTERNAL"
    assert value(definition, "q:Diameter") == pytest.approx(hole["nominal_diameter_mm"],
                                                            abs=1e-3)
    axis = np.array(hole["axis"])
    assert abs(numbers(one(nominal, "q:Axis/q:Direction")) @ axis) == pytest.approx(1, abs=1e-6)
    np.testing.assert_allclose(numbers(one(nominal, "q:Axis/q:AxisPoint"))[:2],
                               hole["nominal_centre_mm"][:2], atol=1e-3)
    meas = one(root, f"//q:MeasuredFeatures/*[q:FeatureItemId='{item.get('id')}']")
    assert value(meas, "q:Diameter") == pytest.approx(hole["actual_diameter_mm"], abs=0.002)
    size = next(c for c in run.doc["characteristics"] if c["id"] == "5")
    assert value(meas, "q:Diameter") == pytest.approx(size["value"], abs=1e-6)
    made = np.add(hole["nominal_centre_mm"], hole["actual_centre_offset_mm"])[:2]
    np.testing.assert_allclose(numbers(one(meas, "q:Axis/q:AxisPoint"))[:2], made, atol=0.004)


def test_plan_transform_is_the_pose_of_the_points(plan_run):
    """The transform is the plan's alignment: it carries the measured file's points onto the
    point set's (nominal frame), which the registration's pose does not."""
    run = plan_run
    root = parse_valid(run.qif())
    t = one(root, "//q:ActualTransforms/q:Transform")
    R = np.column_stack([numbers(one(t, f"q:Rotation/q:{a}Direction")) for a in "XYZ"])
    with open(run.csv, newline="") as f:
        measured = np.array([[float(r[k]) for k in "xyz"] for r in csv.DictReader(f)])
    points = numbers(one(root, "//q:MeasuredPointSet/q:Points")).reshape(-1, 3)
    np.testing.assert_allclose(measured @ R.T + numbers(one(t, "q:Origin")), points, atol=1e-5)
    registration = np.asarray(run.doc["transform"])
    assert np.abs(measured @ registration[:3, :3].T + registration[:3, 3] - points).max() > 1e-3


def test_plan_certificate_attaches_the_plan_document(plan_run):
    """The certificate of a plan run (--report) carries the same plan characteristics in its
    results.qif as the document written from its JSON."""
    from pyhanko.pdf_utils.reader import PdfFileReader

    from reports.signing import embedded_files

    with open(plan_run.pdf, "rb") as f:
        attached = embedded_files(PdfFileReader(f))["results.qif"]
    seen = []
    for root in (parse_valid(attached), parse_valid(plan_run.qif())):
        seen.append([(one(item, "q:CharacteristicDesignator/q:Designator").text, local(m),
                      one(m, "q:Status/q:CharacteristicStatusEnum").text, m.findtext(
                          "{%s}Value" % NS["q"]))
                     for cid in "12345" for item, _, _, m in [characteristic(root, cid)]])
        assert len(root.xpath("//q:DatumReferenceFrame", namespaces=NS)) == 1
    assert seen[0] == seen[1]


def test_plan_zone_over_all_points_is_a_characteristic_of_the_nominal(tmp_path):
    """--tol with a plan: the zone over all points is one more characteristic ('tol'), a
    profile on the nominal's feature, the one whose measurement carries the point set."""
    run = Inspection(tmp_path, SEAT, ["--plan", SEAT_PLAN, "--tol", "0.05"])
    root = parse_valid(run.qif())
    tol = next(c for c in run.doc["characteristics"] if c["id"] == "tol")
    item, definition, _, meas = characteristic(root, "tol")
    assert local(meas) == "SurfaceProfileCharacteristicMeasurement"
    assert value(meas, "q:Value") == pytest.approx(tol["value"], abs=1e-6)
    assert value(definition, "q:ToleranceValue") == pytest.approx(0.1, abs=1e-9)
    fm = by_id(root, one(meas, "q:FeatureMeasurementIds/q:Id").text)
    assert one(fm, "q:PointList/q:WholePointSetId").text == \
        one(root, "//q:MeasuredPointSet").get("id")
    assert len(one(root, "//q:CharacteristicItems")) == len(run.doc["characteristics"]) == 6


def test_plan_labels_and_unmeasured_characteristics(plan_run):
    """A datum label that is no xs:NMTOKEN is written valid (its text kept in an attribute);
    a characteristic that could not be measured has no Value and is INDETERMINATE."""
    doc = copy.deepcopy(plan_run.doc)
    text = json.dumps({k: doc[k] for k in ("features", "characteristics", "alignment")})
    doc.update(json.loads(text.replace('"label": "A"', '"label": "A 1"')
                          .replace('["A", "B", "C"]', '["A 1", "B", "C"]')))
    c = doc["characteristics"][3]
    c.update(value=None, verdict="INCONCLUSIVE", reason="its datums cannot place the part")
    root = parse_valid(plan_run.qif(doc))
    primary = one(root, "//q:DatumDefinition[q:DatumLabel='A_1']")
    assert one(primary, "q:Attributes/q:AttributeStr[@name='qa-inspect:label']").get(
        "value") == "A 1"
    meas = characteristic(root, "4")[3]
    assert one(meas, "q:Status/q:CharacteristicStatusEnum").text == "INDETERMINATE"
    assert not meas.xpath("q:Value", namespaces=NS)


def test_schema_checks_the_plan_parts(plan_run):
    """The validation is worth something for the plan's parts too: a datum reference frame
    naming no datum definition (key/keyref), and a position without its zone shape, fail."""
    good = plan_run.qif()
    root = etree.fromstring(good)
    root.xpath("//q:DatumReferenceFrame//q:DatumDefinitionId", namespaces=NS)[2].text = "9999"
    assert not SCHEMA.validate(etree.ElementTree(root))
    root = etree.fromstring(good)
    shape = one(root, "//q:PositionCharacteristicDefinition/q:ZoneShape")
    shape.getparent().remove(shape)
    assert not SCHEMA.validate(etree.ElementTree(root))
    assert SCHEMA.validate(etree.ElementTree(etree.fromstring(good)))
