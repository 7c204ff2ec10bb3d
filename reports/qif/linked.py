"""A QIF plan answered in its own document: QIF in, QIF out.

With a QIF plan (a model-based definition, or a QIF Plan), the results document is the plan's
own QIF document carried through, its ids unchanged: its units, datums and datum reference
frames, measurement resources, product, features and characteristics (definitions, nominals
and any items), and its measurement plan. What the inspection adds comes after its ids (from
the plan's ``idMax`` + 1):

- a ``…FeatureItem`` for every feature nominal a characteristic was judged on that has none
  (the NIST models state definitions and nominals only), and a ``…CharacteristicItem`` for
  every characteristic judged (the plan's own item where it states exactly one for it and it
  was judged once; a size judged on each of its features, ``ID.1``, ``ID.2`` …, gets one item
  per feature). Each item names its nominal: ``CharacteristicNominalId`` is the plan's id,
  the JSON's characteristic ``id`` (or the part before ``.k``);
- the measured part as the plain results document has it (reports.qif): the whole nominal's
  feature and its point set, a profile over all points when the zone is part of the verdict;
- ``Results``: per feature item a ``…FeatureMeasurement`` (the least-squares geometry where
  the plan's feature is the plane, cylinder or sphere the inspection fitted), per
  characteristic item a ``…CharacteristicMeasurement`` of the plan's own kind with its status
  and value, and every characteristic the plan could not judge as INDETERMINATE with its
  reason: nothing of the plan is dropped.

Units: the plan's. Lengths of the measured geometry (points, deviations, the transform's
origin, fitted features) are in its primary linear unit times its declared
``ScaleCoefficient``, characteristic values in its PMI linear unit (or primary unit), angles
in its angular unit. The plan's ``Results``, ``Statistics``, rules and user data are not
carried (these results replace them).
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
from lxml import etree

from .measured import write_results
from .model import QIF_NAMESPACE, Char, Feature, Qif
from .nominal import (characteristic_definition, characteristic_item, characteristic_nominal,
                      feature_definition, feature_item, feature_nominal, write_header,
                      write_resources)

_BEFORE_RESOURCES = ("StandardsDefinitions", "SoftwareDefinitions", "AlgorithmDefinitions",
                     "PreInspectionTraceability", "FileUnits", "DatumDefinitions",
                     "DatumTargetDefinitions", "Transforms", "CoordinateSystems",
                     "DatumReferenceFrames")
_AFTER_RESOURCES = ("ThreadSpecifications", "Product", "Features", "FeatureZones",
                    "Characteristics", "Plan")
"""The QIFDocument's elements (QIFDocument.xsd, in its order) carried from the plan; the
measurement resources stand between them."""
_ANGLES = ("Angle",)
"""Characteristic kinds (the inspection's) whose values are angles, not lengths."""


def linked_results_document(doc: dict, source, pts, dev, inside, labels, outlier) -> bytes:
    """The QIF results document of an inspection judged by the QIF plan ``source``
    (engine.io.qif_plan.QifSource: the file read again, checked to be the one inspected);
    the other arguments as for reports.qif.qif_results_document (already checked)."""
    root = source.root
    q = _in_units(Qif.of(doc, pts, dev, inside, labels, outlier, after_id=_largest_id(root)),
                  source.units)
    if root.find("{*}MeasurementResources") is not None:  # the plan's devices stand
        q = replace(q, ids=replace(q.ids, device=None))
    link = _Link(root, q)
    link.judged(doc)
    link.not_judged((doc.get("plan_faces") or {}).get("not_judged") or ())
    q = link.document()
    out: list[str] = []
    w = out.append
    write_header(w, q)
    for name in _BEFORE_RESOURCES:
        _carry(w, root.find("{*}" + name))
    resources = root.find("{*}MeasurementResources")
    if resources is None:
        write_resources(w, q)
    else:
        _carry(w, resources)
    for name in _AFTER_RESOURCES:
        e = root.find("{*}" + name)
        if name == "Features":
            e = link.features_with_items(e)
        elif name == "Characteristics":
            e = link.characteristics_with_items(e)
        _carry(w, e)
    write_results(w, q)
    return "".join(out).encode("utf-8")


def _largest_id(root) -> int:
    """The largest id the plan uses (its ``idMax``, or any id above it)."""
    ids = [e.get("id") for e in root.iter() if isinstance(e.tag, str)] + [root.get("idMax")]
    return max((int(v) for v in ids if v is not None and v.isdigit()), default=0)


def _local(e) -> str:
    return etree.QName(e).localname


def _carry(w, e) -> None:
    if e is not None:
        w("  " + etree.tostring(e, encoding="unicode", with_tail=False) + "\n")


class _Link:
    """The plan's features and characteristics as the results reference them: its items, the
    items added, and the measurements of both."""

    def __init__(self, root, q: Qif):
        self.q = q
        self.ids = itertools.count(q.id_max + 1)
        self.nominals = {e.get("id"): e for e in _children(root, "Features", "FeatureNominals")}
        self.char_nominals = {e.get("id"): e for e in _children(
            root, "Characteristics", "CharacteristicNominals")}
        self.plan_items: dict[str, list] = {}  # feature nominal id -> its items' ids
        self.item_nominal: dict[str, str] = {}  # feature item id -> its nominal's id
        for e in _children(root, "Features", "FeatureItems"):
            self.plan_items.setdefault(_text(e, "FeatureNominalId"), []).append(e.get("id"))
            self.item_nominal[e.get("id")] = _text(e, "FeatureNominalId")
        self.plan_char_items: dict[str, list] = {}  # characteristic nominal id -> its items
        for e in _children(root, "Characteristics", "CharacteristicItems"):
            self.plan_char_items.setdefault(_text(e, "CharacteristicNominalId"), []).append(e)
        self.ours = {f.name: f for f in q.features if not f.whole}
        self.measured: dict[str, Feature] = {}  # plan feature nominal id -> its measurement
        self.new_feature_items: list[str] = []
        self.new_char_items: list[str] = []
        self.own: list[Char] = []  # the inspection's own characteristics (no plan id)
        self.chars: list[Char] = []

    def feature(self, fid: str) -> Feature:
        """The measurement of the plan's feature nominal ``fid`` (its item's, added if the plan
        states none), with the inspection's fitted geometry where the kinds agree."""
        if fid in self.measured:
            return self.measured[fid]
        e = self.nominals.get(fid)
        if e is None:
            raise KeyError(f"the plan has no feature nominal {fid}")
        kind = _local(e)[:-len("FeatureNominal")]
        name = _text(e, "Name") or f"feature {fid}"
        items = self.plan_items.get(fid) or []
        if items:
            item = int(items[0])
        else:
            item = next(self.ids)
            self.new_feature_items.append(feature_item(kind, item, fid, name))
        ours = self.ours.get(f"qif:{fid}")
        measured = ours.measured if ours is not None and ours.kind == kind else None
        f = Feature(name, kind, 0, int(fid), item, next(self.ids), measured=measured)
        self.measured[fid] = f
        return f

    def judged(self, doc: dict) -> None:
        """The characteristics judged (the JSON's, in order, as Qif.of made them)."""
        entries = doc.get("characteristics") or []
        per_nominal: dict[str, int] = {}
        for c in entries:
            nid = _plan_id(c)
            if nid is not None:
                per_nominal[nid] = per_nominal.get(nid, 0) + 1
        for c, char in zip(entries, self.q.chars):
            nid = _plan_id(c)
            if nid is None or nid not in self.char_nominals:
                self.own.append(char)
                continue
            region = str(c.get("region") or "")
            fids = ([t.partition("/")[0] for t in region[4:].split("+")]
                    if region.startswith("qif:") else self._nominal_features(nid))
            self.chars.append(self._linked(char, nid, [f for f in fids if f in self.nominals],
                                           per_nominal[nid] == 1))

    def not_judged(self, entries) -> None:
        """The plan's characteristics not judged: INDETERMINATE, their reason as description."""
        for n in entries:
            nid = str(n.get("id"))
            if nid not in self.char_nominals:
                continue
            base = Char("", 0, 0, 0, 0, self.q.features[0], str(n.get("name") or nid), None,
                        "", 0.0, 0.0, None, None, "INCONCLUSIVE", None,
                        f"not judged: {n.get('reason', '')}")
            self.chars.append(self._linked(base, nid, self._nominal_features(nid), True))

    def _nominal_features(self, nid: str) -> list[str]:
        """The feature nominals of the plan's characteristic ``nid``: those its nominal lists,
        else those of the feature items its own items list (a QIF Plan's way)."""
        listed = _ids(self.char_nominals[nid], "FeatureNominalIds")
        if not listed:
            listed = [self.item_nominal.get(i, "") for item in self.plan_char_items.get(nid, [])
                      for i in _ids(item, "FeatureItemIds")]
        return list(dict.fromkeys(f for f in listed if f in self.nominals))

    def _linked(self, char: Char, nid: str, fids: list[str], once: bool) -> Char:
        e = self.char_nominals[nid]
        kind = _local(e)[:-len("CharacteristicNominal")]
        features = [self.feature(f) for f in fids]
        items = self.plan_char_items.get(nid) or []
        # The plan's own item where it states one, and on the features judged.
        if once and len(items) == 1 and {self.item_nominal.get(i) for i in _ids(
                items[0], "FeatureItemIds")} <= set(fids):
            item = int(items[0].get("id"))
        else:
            item = next(self.ids)
            self.new_char_items.append(characteristic_item(
                kind, item, nid, _text(e, "Name") or char.name, _designator(e),
                [f.item for f in features], self.q.ids.device))
        return replace(char, kind=kind, item=item, measurement=next(self.ids),
                       feature=features[0] if features else self.q.features[0],
                       feature_measurements=tuple(f.measurement for f in features)
                       or (self.q.features[0].measurement,),
                       # A Bonus is written for the inspection's Position only.
                       bonus=char.bonus if char.kind == kind else None)

    def document(self) -> Qif:
        whole = self.q.features[0]
        return replace(self.q, features=(whole, *self.measured.values()),
                       chars=(*self.chars, *self.own), id_max=next(self.ids) - 1)

    def features_with_items(self, e):
        """The plan's Features with the whole nominal's feature and the items added."""
        whole = self.q.features[0]
        return _with(e, "Features", [("FeatureDefinitions", [feature_definition(whole)]),
                                     ("FeatureNominals", [feature_nominal(whole)]),
                                     ("FeatureItems", [feature_item(whole.kind, whole.item,
                                                                    whole.nominal_id,
                                                                    whole.name)]
                                      + self.new_feature_items)])

    def characteristics_with_items(self, e):
        """The plan's Characteristics with the inspection's own characteristics (a zone over all
        points) and the items added."""
        own = self.own
        return _with(e, "Characteristics", [
            ("CharacteristicDefinitions", [characteristic_definition(c) for c in own]),
            ("CharacteristicNominals", [characteristic_nominal(c) for c in own]),
            ("CharacteristicItems", [characteristic_item(
                c.kind, c.item, c.nominal_id, c.name, c.designator, [c.feature.item],
                self.q.ids.device) for c in own] + self.new_char_items)])


_ORDER = {"Features": ("FeatureDefinitions", "FeatureNominals", "FeatureItems",
                       "NominalPointSets"),
          "Characteristics": ("FormalStandardId", "CharacteristicDefinitions",
                              "DefaultCharacteristicDefinitions", "DefaultToleranceDefinitions",
                              "CharacteristicNominals", "CharacteristicItems",
                              "CharacteristicGroups", "SimultaneousRequirementGroups")}
"""The children of Features and Characteristics in the schema's order."""


def _with(e, name: str, additions: list[tuple[str, list[str]]]):
    """A copy of the plan's ``name`` element (an empty one when it has none) with the
    elements ``additions`` (XML snippets) appended to its lists, each list's ``n`` updated."""
    out = etree.Element(f"{{{QIF_NAMESPACE}}}{name}") if e is None else etree.fromstring(
        etree.tostring(e))
    for list_name, snippets in additions:
        if not snippets:
            continue
        target = out.find("{*}" + list_name)
        if target is None:
            target = etree.Element(f"{{{QIF_NAMESPACE}}}{list_name}")
            order = _ORDER[name]
            after = [c for c in out if isinstance(c.tag, str)
                     and _local(c) in order[:order.index(list_name)]]
            if after:
                after[-1].addnext(target)
            else:
                out.insert(0, target)
        wrapper = etree.fromstring(f'<w xmlns="{QIF_NAMESPACE}">{"".join(snippets)}</w>')
        for child in list(wrapper):
            target.append(child)
        target.set("n", str(sum(1 for c in target if isinstance(c.tag, str))))
    return out


def _children(root, *path: str) -> list:
    parent = root.find("/".join("{*}" + p for p in path))
    return [] if parent is None else [c for c in parent if isinstance(c.tag, str)]


def _ids(e, name: str) -> list[str]:
    """The ids of the list ``name`` (``<name n=".."><Id>..</Id>…``) under ``e``."""
    return [i.text.strip() for i in e.iterfind(f"{{*}}{name}/{{*}}Id") if i.text]


def _text(e, name: str) -> str:
    return (e.findtext("{*}" + name) or "").strip()


def _designator(e) -> str | None:
    return _text(e, "CharacteristicDesignator/{*}Designator") or None


def _plan_id(c: dict) -> str | None:
    """The plan's characteristic nominal id a judged characteristic answers: its source item's
    id (``"PositionCharacteristicNominal 1443"``), None for the inspection's own."""
    item = str((c.get("source") or {}).get("item") or "")
    return item.split()[-1] if item else None


def _in_units(q: Qif, units) -> Qif:
    """``q`` with its lengths and angles in the plan's units (module docstring); its
    characteristics still of the inspection's kinds (an angle's value is one)."""
    g = units.scale / units.mm[units.unit]
    p = 1.0 / units.mm[units.pmi_unit]
    a = 1.0 / units.degrees.get(units.angle_unit, 1.0) if units.angle_unit else 1.0
    if g == p == a == 1.0:
        return q
    T = q.T.copy()
    T[:3, 3] *= g

    def geometry(m):
        if not m:
            return m
        return {k: (np.asarray(v) * g if k in ("point", "centre") else
                    v * g if k in ("diameter", "form_error") and v is not None else v)
                for k, v in m.items()}

    def value(c: Char, v):
        return None if v is None else v * (a if c.kind in _ANGLES else p)

    chars = tuple(replace(c, value=value(c, c.value), bonus=value(c, c.bonus),
                          worst=None if c.worst is None else (c.worst[0] * p, c.worst[1] * p))
                  for c in q.chars)
    features = tuple(replace(f, measured=geometry(f.measured)) for f in q.features)
    return replace(q, pts=q.pts * g, dev=q.dev * g, T=T, chars=chars, features=features,
                   length_unit=units.unit + (f" x {units.scale:g} (the plan's scale)"
                                             if units.scale != 1.0 else ""))
