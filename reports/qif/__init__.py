"""QIF 3.0 results document of one inspection (ANSI/DMSC QIF 3.0, ISO 23952).

:func:`qif_results_document` turns the JSON results document (:mod:`reports.results`) and the
per-point arrays into a ``QIFDocument`` (namespace ``http://qifstandards.org/xsd/qif3``,
``versionQIF="3.0.0"``) that validates against the official ``QIFDocument.xsd``.

Units: every length is in millimetres (``FileUnits/PrimaryUnits/LinearUnit`` = mm).
Sign: a deviation is positive along the nominal's outward normal (excess material), as QIF's
``PointDeviationType/Deviation`` defines it ("positive in the direction of the normal vector").

What carries what:

- ``Header/Application/Name``: "qa-inspect <version>"; ``Header/Author``: inspector and
  organisation when the certificate names them.
- ``FileUnits``: mm. ``MeasurementResources/MeasurementDevices/MeasurementDevice``: only when the
  certificate names a device (or its serial, calibration date or probe): ``Name``,
  ``SerialNumber``, and ``AttributeStr`` "qa-inspect:probe" (probe and stylus) and
  "qa-inspect:calibration-date" (YYYY-MM-DD; a QIF ``Calibration`` needs an expiry date the
  certificate does not state); the point set and the characteristic measurement refer to it.
- ``Product/PartSet/Part``: ``Header/Name`` = part name, ``ModelNumber`` = part number,
  ``Version`` = revision, ``AttributeStr`` "qa-inspect:drawing" = the drawing number;
  ``DefinitionExternal/DigitalModel`` = the nominal file (name, format, the CAD revision as its
  ``File/Version``, sha256 in its ``Description``).
- ``Features``: one freeform feature for the nominal, ``OtherSurfaceFeature*`` for a 3D nominal,
  ``OtherCurveFeature*`` for a 2D template (QIF has no analytic type for either).
- ``Characteristics``: one profile characteristic on that feature, ``SurfaceProfile*`` (3D) or
  ``LineProfile*`` (2D, ``Vector`` 0 0 1: the template lies in its XY plane). The zone
  [lower, upper] is ``ToleranceValue`` = upper - lower plus, unless symmetric,
  ``OuterDisposition`` = upper (the ASME form of an unequal/offset zone:
  lower = OuterDisposition - ToleranceValue).
- ``Results/MeasurementResultsSet/MeasurementResults``:
  ``InspectionTraceability`` (organisation, order, certificate number as ``ReportNumber``,
  inspector as ``InspectionOperator``, issue time as ``ReportPreparationDate``, the part's
  temperature (°C) as ``AttributeD1`` "qa-inspect:temperature-c" and the measurement program as
  ``AttributeStr`` "qa-inspect:measurement-program");
  ``ExternalFileReferences``: the measured points file and its sha256;
  ``MeasuredFeatures``: the feature measurement, pointing at the point set and at the
  registration transform;
  ``MeasuredPointSets/MeasuredPointSet``: every measured point in input order, ``Points`` =
  x y z in the nominal frame (one point a line), ``Deviations`` = signed deviation (one a line),
  plus ``AttributeStr`` per-point flags ("qa-inspect:in-tolerance",
  "qa-inspect:excluded-from-alignment" (a gross outlier the fit left out; judged all the same):
  one character '1'/'0' per point) and labels ("qa-inspect:labels", a JSON array of strings);
  ``MeasuredCharacteristics``: the profile measurement: ``Status`` (PASS / FAIL / INDETERMINATE
  for ACCEPT / REJECT / INCONCLUSIVE), ``Value`` = 2 * max |d - c| with c = (lower + upper) / 2,
  the width of the smallest zone centred like the tolerance zone that holds every point (so
  Value <= ToleranceValue exactly when every point is in tolerance; 2 * max |d| for a symmetric
  zone), ``WorstPositiveDeviation`` = max d, ``WorstNegativeDeviation`` = min d, and the
  verdict's reasons in ``Description``;
  ``ActualTransforms/Transform``: T_nominal_measured (before = measured, after = nominal);
  ``InspectionStatus``: PASS / FAIL / UNKNOWN; ``ActualComponentIds`` and
  ``Results/ActualComponentSets``: the serial number, when given.

With an inspection plan (the JSON's ``characteristics``, ``features`` and ``alignment``,
:func:`reports.results.plan_json`) the plan's characteristics take the place of the profile over
all points, as producers of CMM results write them (CheckMate, NIST's CTC models):

- ``DatumDefinitions``: one per datum, ``DatumLabel`` (an xs:NMTOKEN: other characters become
  '_', the label itself then in ``AttributeStr`` "qa-inspect:label") and ``FeatureNominalIds``:
  its datum feature.
- ``DatumReferenceFrames``: one per distinct datum sequence (the alignment's, each
  characteristic's), ``SimpleDatum`` per datum in precedence (PRIMARY, SECONDARY, TERTIARY),
  ``MaterialModifier`` NONE (no modifier on the drawing), ``ReferencedComponent`` ACTUAL (the
  datums are established on the measured part), ``SubstituteFeatureAlgorithm`` = the datum
  simulator: ONESIDED (a tangent plane), MAXINSCRIBED / MINCIRCUMSCRIBED (a tangent hole /
  shaft), LEASTSQUARES.
- ``Features``: besides the nominal's freeform feature, one per region a datum or characteristic
  uses: ``PlaneFeature*`` (nominal ``Location``, ``Normal``), ``CylinderFeature*`` (definition
  ``InternalExternal``, ``Diameter``; nominal ``Axis``), ``SphereFeature*`` (nominal
  ``Location``), the least-squares fit of the region's nominal points; a profile's region, or
  one whose nominal points do not determine its feature, is an ``OtherSurfaceFeature*``. The
  feature measurement gives the least-squares fit of its measured points (``Location`` /
  ``Normal``, ``Axis``, ``Diameter``, ``Form`` = peak to valley of the residuals) in the frame
  of the point set.
- ``Characteristics``: per plan characteristic, in the plan's order, its item's
  ``CharacteristicDesignator/Designator`` = the plan's id (the balloon): profile:
  ``SurfaceProfile*`` (zone as above, ``DatumReferenceFrameId`` when it has datums); flatness:
  ``Flatness*`` (``ToleranceValue``); position: ``Position*`` (``ToleranceValue`` = the
  diameter of the zone, ``DatumReferenceFrameId``, ``MaterialCondition`` NONE, ``ZoneShape``
  ``DiametricalZone``); size: ``Diameter*`` (``TargetValue`` = the nominal diameter,
  ``Tolerance`` ``MaxValue``/``MinValue`` = the limits about it). The zone over all points
  (``tol``), when it is part of the verdict, is a profile on the nominal's feature.
- ``MeasuredCharacteristics``: per characteristic ``Status`` (as above), ``Value`` = the JSON's
  value in the drawing's convention (absent when it could not be measured) and its reason.
- ``ActualTransforms/Transform``: the plan's alignment, the pose of the points.

With a QIF plan (``plan``: :func:`plan_source`) the document is instead that plan's own,
carried through with its ids, and the results reference its characteristic and feature
nominals through items: :mod:`.linked`.

Ids are consecutive integers from 1 (``idMax`` on the root). The document is deterministic: no
clock is read; ``QPId`` is a UUID 5 of the inputs' sha256s, the certificate number and the zone
(and the plan's sha256).
Numbers are written with 6 decimals (1 nm), the transform and unit vectors exactly (shortest
round-trip repr).

The code: :mod:`.document` (:func:`qif_results_document`, the entry), :mod:`.linked` (a QIF
plan's own document answered), :mod:`.model` (what the document states, its ids, features,
characteristics, datums and frames, made from the JSON), :mod:`.nominal` and :mod:`.measured`
(the writers of the sections: the part as defined, then as measured), :mod:`.text` (numbers
and words as QIF's XML spells them).
"""

from .document import plan_source, qif_results_document
from .model import DEVICE_KEYS, QIF_NAMESPACE, QIF_VERSION, QIFError

__all__ = ["DEVICE_KEYS", "QIF_NAMESPACE", "QIF_VERSION", "QIFError", "plan_source",
           "qif_results_document"]
