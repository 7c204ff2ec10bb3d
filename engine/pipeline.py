"""One inspection from files: read the nominal and the measured points, register, judge.

The command line, the certificate's ``verify --nominal/--measured`` re-run and the desktop app all
go through :func:`run_files`, so one set of settings gives one answer everywhere; a batch of parts
reads the nominal once (:func:`load_nominal`) and inspects each measured file against it
(:func:`inspect_measured`), which gives the same answers. Nothing here
writes an output: the results document, the CSV, QIF and the certificate are made from the
:class:`Run` by ``reports`` (``reports.results.run_document``).
"""

from __future__ import annotations

import dataclasses
import functools
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .choices import DecisionRule
from .errors import InputError, SettingsError
from .inspection import InspectionResult, inspect, inspect_2d
from .io import formats, is_template, load_point_set, sha256_of
from .gdt.plan import Plan
from .pointset import PointSet
from .nominal import Nominal, copies_nominal
from .progress import Callback, report, reporting, within
from .registration_types import RegistrationSettings
from .seeds import rng
from .scene import Selection, check_box, check_plane_distance, extent_warning, select_points
from .scene_part import on_the_table, the_part
from .settings import InspectionSettings
from .hints import not_planar_hint, swap_hint
from .step_model import (ExactDistances, StepFaces, exact_features,
                         face_groups, face_rivals, face_sample, step_facts)
from .tolerance import Tolerance, check_zone
from .verdict import ACCEPT, INCONCLUSIVE

if TYPE_CHECKING:
    from .io.step import StepNominal
    from .io.templates import TemplateFile


@dataclass(frozen=True)
class InputRecord:
    """One input file as the results cite it."""

    role: str  # "nominal" or "measured"
    path: str
    sha256: str
    n_points: int | None
    """Points in the file (None for a 2D template, which has primitives instead)."""
    n_primitives: int | None = None
    """Line segments and arcs of a 2D template."""
    n_faces: int | None = None
    """Faces of a STEP model."""


@dataclass(frozen=True)
class Run:
    """One inspection and what its outputs need.

    nominal : the 3D nominal (None for a 2D template); template : the 2D template file (None for
    a 3D nominal); measured : the measured point set as read; timings_s : seconds spent
    ``load``-ing the files, in ``register`` and ``deviation``, and in ``total``; plan : the
    inspection plan as read (None without one), whose ``part`` the certificate names;
    selection : which of the measured file's points were inspected (engine.scene.Selection;
    None: every one, ``measured`` is then the file's point set, else the points kept);
    warnings : what the user should know about the inputs, one sentence each (the command
    line prints them, the JSON lists them, the app shows them); faces : a STEP nominal's faces
    (engine.step_model.StepFaces: the face of each nominal sample, the plan regions' groups),
    None for another nominal; step : the STEP model read as the nominal
    (engine.io.step.StepNominal, not picklable), else None.
    """

    settings: InspectionSettings
    result: InspectionResult
    inputs: list[InputRecord]
    measured: PointSet
    nominal: Nominal | None
    template: TemplateFile | None
    timings_s: dict
    plan: Plan | None = None
    selection: Selection | None = None
    warnings: tuple[str, ...] = ()
    faces: StepFaces | None = None
    step: StepNominal | None = None

    @functools.cached_property
    def worst_order(self) -> np.ndarray:
        """Point indices from farthest outside the zone to deepest inside (stable)."""
        r = self.result
        return np.argsort(-r.tolerance.excess(r.deviations.signed), kind="stable")


def inspection_settings(tol: Tolerance | None, plan: str | None = None,
                        **options) -> InspectionSettings:
    """The settings of an inspection whose zone the user may leave to its plan (the command
    line's ``--tol`` and ``--plan``, the desktop app's zone and plan).

    tol : the zone the user gave (mm), or None. Given, it is part of the verdict: the verdict
        without a plan, one more profile characteristic over all points with one. None with a
        plan: the plan's characteristics are the requirement, and the zone of the per-point
        statistics is the plan's (engine.gdt.characteristics.statistics_zone), outside the verdict.
    plan : the inspection plan's path (TOML), or None; read here when it must give the zone.
    options : the other InspectionSettings fields (layers, units, scale, fit, decision_rule,
        instrument). A decision_rule of None is "guarded" when an instrument is stated (the
        option's, or the plan's ``[measurement]``), else "simple".

    Raises SettingsError without a zone or a plan, InputError for a plan that cannot be read.
    """
    read = None
    if plan is not None and (tol is None or options.get("decision_rule") is None):
        from .io.plan import read_plan

        read = read_plan(plan)
    if options.get("decision_rule") is None:
        stated = instrument_of(options.get("instrument"), read)
        options["decision_rule"] = (DecisionRule.GUARDED if stated is not None
                                    and stated.states_anything else DecisionRule.SIMPLE)
    if tol is None:  # (the plan was read above whenever it is given without a zone)
        return zone_of(InspectionSettings(None, None, plan=plan, **options), read)
    return InspectionSettings(tol.lower, tol.upper, plan=plan, zone_in_verdict=True, **options)


def zone_of(settings: InspectionSettings, plan: Plan | None) -> InspectionSettings:
    """``settings`` with a zone: as they are when they give one; when they leave it to the
    plan (tol_lower and tol_upper None, as ``--plan`` without ``--tol``), the plan's statistics
    zone (engine.gdt.characteristics.statistics_zone), outside the verdict. SettingsError
    for one limit without the other, or no zone and no plan."""
    lower, upper = settings.tol_lower, settings.tol_upper
    if lower is not None and upper is not None:
        return settings
    if lower is not None or upper is not None:
        raise SettingsError("a tolerance zone needs both its limits (tol_lower and tol_upper, "
                            "mm), or neither when a plan gives the requirement")
    if plan is None:
        raise SettingsError("a tolerance zone or an inspection plan is required")
    from .gdt.characteristics import statistics_zone

    zone = statistics_zone(plan)
    return dataclasses.replace(settings, tol_lower=zone.lower, tol_upper=zone.upper,
                               zone_in_verdict=False)


def instrument_of(given, plan: Plan | None):
    """The instrument an inspection states (engine.uncertainty.Instrument): the one ``given``
    (the command line's ``--uncertainty``, the app's session), else the plan's
    ``[measurement]``, else None."""
    if given is not None:
        return given
    return None if plan is None else plan.measurement.instrument


def check_settings(nominal_path: str, settings: InspectionSettings) -> None:
    """Raise SettingsError for options that do not apply to this kind of nominal, or a crop
    box, plane distance or seed that is none."""
    if isinstance(settings.seed, bool) or not isinstance(settings.seed, int) or settings.seed < 0:
        raise SettingsError(f"the seed must be a whole number >= 0, not {settings.seed!r}")
    if settings.crop is not None:
        check_box(settings.crop)
    check_plane_distance(settings.plane_distance)
    if settings.plane_distance is not None and not settings.remove_plane:
        raise SettingsError("a plane removal distance applies with --remove-plane only")
    kind = formats.kind_of(nominal_path)
    if settings.remove_plane and kind in formats.TEMPLATE_KINDS:
        raise SettingsError("--remove-plane applies to 3D nominals: the measured points of a "
                            "2D template lie in its plane")
    if kind == formats.DXF:
        if settings.scale is not None:
            raise SettingsError("--scale applies to airfoil ordinate templates (.dat) only")
    elif kind == formats.AIRFOIL:
        if settings.scale is None:
            raise SettingsError("an airfoil ordinate template needs --scale CHORD (the chord "
                                "length in mm)")
        if settings.layers or settings.units:
            raise SettingsError("--layer and --units apply to DXF templates only")
    elif settings.layers or settings.units or settings.scale is not None:
        raise SettingsError("--layer, --units and --scale apply to 2D templates (.dxf, .dat) "
                            "only")


def run_files(nominal_path: str, measured_path: str, settings: InspectionSettings,
              progress: Callback | None = None) -> Run:
    """Read both files and inspect. Raises InputError / InputNotFoundError for bad files and
    SettingsError for options that do not fit the files.

    progress : called as progress(stage, fraction) at each stage and iteration (see
        engine.progress); it may raise engine.errors.Cancelled to stop the run.
    """
    with reporting(progress):
        return _run_files(nominal_path, measured_path, settings)


@dataclass(frozen=True)
class LoadedNominal:
    """What an inspection reads besides the measured file, read once for any number of measured
    files (:func:`load_nominal`, then :func:`inspect_measured` per file).

    source : the nominal file as read (a point set, a 2D template or a STEP model);
    nominal : the engine's 3D nominal built from it (None for a 2D template). Its search
        structures are built on the first inspection and reused by the next ones;
    plan : the inspection plan of ``settings.plan`` as read, and its record (None without one);
    settings : the settings it was read with (template layers, units, scale, plan), which the
        inspections use; load_s : seconds spent reading and preparing it.

    Picklable (to share with other processes, e.g. Dask workers) unless the nominal is a STEP
    model, whose OpenCascade objects are not: see :attr:`picklable`.
    """

    source: "_Nominal"
    nominal: Nominal | None
    plan: Plan | None
    plan_record: InputRecord | None
    settings: InspectionSettings
    load_s: float

    @property
    def path(self) -> str:
        return self.source.record.path

    @property
    def picklable(self) -> bool:
        """False for a STEP model (its OpenCascade shapes cannot be pickled)."""
        return self.source.step is None


def load_nominal(nominal_path: str, settings: InspectionSettings) -> LoadedNominal:
    """Read the nominal (and the plan of ``settings``) and prepare it for inspections.

    Raises InputError / InputNotFoundError for a file that cannot be read and SettingsError for
    options that do not fit it (the checks of :func:`run_files`).
    """
    check_settings(nominal_path, settings)
    qif = (settings.plan if settings.plan is not None
           and formats.kind_of(settings.plan) == formats.QIF else None)  # its path
    if qif is not None:  # before reading a nominal that may take a while
        from .io.qif_plan import check_qif_nominal

        check_qif_nominal(qif, nominal_path)
    report("loading the nominal", 0.0)
    t0 = time.perf_counter()
    source = _read_nominal(nominal_path, settings)
    if qif is not None:
        source = _with_qif_faces(source, qif)
    nominal = None
    if source.template is None:
        report("preparing the nominal", 0.0)
        nominal = Nominal.from_point_set(source.points3d, settings.seed)
    plan = record = None
    if settings.plan is not None:
        from .io.plan import read_plan

        plan = read_plan(settings.plan)
        record = InputRecord("plan", settings.plan, plan.sha256, None)
    settings = zone_of(settings, plan)
    check_zones(settings, plan, part_size(source, nominal))
    return LoadedNominal(source, nominal, plan, record, settings, time.perf_counter() - t0)


def _with_qif_faces(source: "_Nominal", plan_path: str) -> "_Nominal":
    """The STEP nominal with the groups of a QIF plan's regions (engine.io.qif_plan) and the
    match kept for the results (JSON ``plan_faces``)."""
    from .io.qif_plan import qif_nominal_groups

    report("matching the QIF plan's features to the faces", 0.0)
    groups, facts = qif_nominal_groups(plan_path, source.step, source.points3d.groups)
    return dataclasses.replace(source, plan_faces=facts,
                               point_set=dataclasses.replace(source.points3d, groups=groups))


def part_size(source: "_Nominal", nominal: Nominal | None) -> float:
    """The part's size, mm: its 3D nominal's bounding-box diagonal, or its 2D template's
    (engine.contour.diagonal)."""
    if source.template is None:
        return source.nominal3d(nominal).diagonal
    from .contour import diagonal

    return diagonal(source.template.template)


def check_zones(settings: InspectionSettings, plan: Plan | None, size: float) -> None:
    """Refuse a zone beyond ``PART_SIZE_RATIO`` x the part's ``size`` (mm) by the rule every
    zone obeys (engine.tolerance.check_zone): a plan's characteristic as InputError naming the
    plan and the characteristic, the settings' zone (--tol, the app's zone) as SettingsError.
    The plan first: without --tol the settings' zone is the plan's."""
    if plan is not None:
        from .io.plan import check_zones as check_plan_zones

        check_plan_zones(plan, size)
    zone = settings.tolerance
    check_zone(zone.lower, zone.upper, size)


def inspect_measured(loaded: LoadedNominal, measured_path: str,
                     progress: Callback | None = None) -> Run:
    """Read one measured file and inspect it against ``loaded`` with ``loaded.settings``: the
    same Run as :func:`run_files` gives for the same files (its ``load`` and ``total`` timings
    count the measured file only). Raises InputError / InputNotFoundError for a bad file.

    progress : as for :func:`run_files`.
    """
    with reporting(progress):
        return _inspect_measured(loaded, measured_path)


def _run_files(nominal_path: str, measured_path: str, settings: InspectionSettings) -> Run:
    if is_template(measured_path):  # before reading a nominal that may take a while
        _refuse_template(nominal_path, measured_path)
    loaded = load_nominal(nominal_path, settings)
    run = _inspect_measured(loaded, measured_path)
    timings = dict(run.timings_s, load=run.timings_s["load"] + loaded.load_s,
                   total=run.timings_s["total"] + loaded.load_s)
    return dataclasses.replace(run, timings_s=timings)


def _refuse_template(nominal_path: str, measured_path: str) -> None:
    raise InputError("a 2D template cannot be the measured points: the template is the "
                     "first argument (NOMINAL), the measured points the second"
                     + ("; the files look swapped" if not is_template(nominal_path) else ""),
                     measured_path)


def _inspect_measured(loaded: LoadedNominal, measured_path: str) -> Run:
    source, nominal, settings, plan = loaded.source, loaded.nominal, loaded.settings, loaded.plan
    nominal_path = loaded.path
    if is_template(measured_path):
        _refuse_template(nominal_path, measured_path)
    report("loading the measured points", 0.0)
    t0 = time.perf_counter()
    measured_ps = load_point_set(measured_path)
    if source.template is None and measured_ps.dim != 3:
        raise InputError(f"the measured points have 2 columns (x y), but the nominal "
                         f"{nominal_path} is a 3D surface: give the measured points as x y "
                         "z, or a 2D template (.dxf, .dat) as NOMINAL for a 2D inspection",
                         measured_ps.path)
    measured_sha = sha256_of(measured_path)
    if measured_sha == source.record.sha256:
        raise InputError(f"the measured file is the nominal {nominal_path} (same content, sha256 "
                         f"{measured_sha[:16]}…): a nominal inspected against itself measures "
                         "nothing", measured_path)
    inputs = [source.record, InputRecord("measured", measured_path, measured_sha, measured_ps.n)]
    if loaded.plan_record is not None:
        inputs.append(loaded.plan_record)
    measured_ps, selection = _select(measured_ps, settings)
    if selection is not None and selection.plane is not None and nominal is not None:
        measured_ps, selection = the_part(nominal, measured_ps, selection, settings)
    if nominal is not None and copies_nominal(measured_ps.points, nominal):
        raise InputError(f"every one of the {measured_ps.n:,} measured points is one of the "
                         f"nominal's points ({nominal_path}) to the last bit: they are a copy "
                         "of the nominal, not a measurement (a measurement carries its "
                         "instrument's noise)", measured_path)
    warnings: tuple[str, ...] = ()
    units = units_hint(source, nominal, measured_ps.points, settings.seed)
    if source.template is None and units is None:  # the units, not a scene to crop
        said = extent_warning(measured_ps.points, source.points3d.points,
                              "measured points" if selection is None else
                              "measured points kept (after the crop and plane removal)")
        warnings = () if said is None else (said,)
    t1 = time.perf_counter()
    if source.template is not None:
        result = _inspect_template(source.template, measured_ps, settings, plan)
    else:
        result = _inspect_3d(source.nominal3d(nominal), source, measured_ps, settings, plan,
                             None if selection is None or selection.plane is None else
                             selection.plane.sigma)
    if result.verdict != ACCEPT:
        hint = (not_planar_hint(result, measured_ps, nominal_path)
                if source.template is not None else swap_hint(source.points3d, measured_ps))
        if hint:
            result = dataclasses.replace(result, reasons=result.reasons + (hint,))
    if units is not None:  # whatever pose was found, it fits a part of another size
        result = dataclasses.replace(result, verdict=INCONCLUSIVE,
                                     reasons=(units,) + tuple(result.reasons))
    if selection is not None and selection.plane is not None and nominal is not None:
        result = on_the_table(result, nominal, measured_ps, selection.plane)
    report("judging", 1.0)
    t2 = time.perf_counter()
    timings = {"load": t1 - t0, "register": result.timings_s["register"],
               "deviation": result.timings_s["deviation"], "total": t2 - t0}
    faces = None if source.step is None else StepFaces(
        source.step.faces, np.asarray(source.step.face_ids), source.points3d.groups or {})
    return Run(settings, result, inputs, measured_ps, nominal, source.template, timings, plan,
               selection, warnings, faces, source.step)


def _select(measured_ps: PointSet, settings: InspectionSettings
            ) -> tuple[PointSet, Selection | None]:
    """The measured points the settings keep (engine.scene.select_points: the crop box, the
    dominant plane removed), and the selection; (the point set, None) when they keep all."""
    if settings.crop is None and not settings.remove_plane:
        return measured_ps, None
    report("selecting the part's points", 0.0)
    selection = select_points(measured_ps.points, settings.crop, settings.remove_plane,
                              settings.plane_distance, f"measured points of {measured_ps.path}",
                              settings.seed)
    return measured_ps.take(selection.kept), selection


def nominal_sizes(source: "_Nominal", nominal: Nominal | None, seed: int) -> np.ndarray:
    """The nominal's principal sizes (engine.units.principal_sizes, mm) over an even sampling
    of it: a template's contours by length (seeded), a mesh's surface by area (its vertices may
    crowd where it curves), else its points. seed : the inspection's (engine.seeds)."""
    from .units import principal_sizes

    if source.template is not None:
        from .contour import points_on

        return principal_sizes(points_on(source.template.template, SIZE_SAMPLES,
                                         rng(seed, SIZE_SEED)))
    nominal = source.nominal3d(nominal)
    if nominal.triangles is not None and len(nominal.triangles):
        return principal_sizes(nominal.area_samples[0])
    return principal_sizes(nominal.points)


SIZE_SAMPLES, SIZE_SEED = 16384, 7
"""Points sampled on a template's contours for its size: their RMS extents are within ~0.5% of
the contours' own."""


def units_hint(source: "_Nominal", nominal: Nominal | None, measured: np.ndarray,
               seed: int) -> str | None:
    """A sentence saying the nominal and the ``measured`` points (n, 3), mm, are in different
    units, naming what would read either right (engine.units.unit_mismatch), or None (``seed``:
    the inspection's, engine.seeds)."""
    from .units import principal_sizes, unit_mismatch

    if source.template is not None:
        kind = "dxf" if formats.kind_of(source.record.path) == formats.DXF else "airfoil"
        mm = source.template.mm_per_unit
    elif source.step is not None:
        kind, mm = "step", source.step.mm_per_unit or 1.0
    else:
        kind, mm = "points", 1.0
    return unit_mismatch(nominal_sizes(source, nominal, seed), principal_sizes(measured), kind,
                         mm)


@dataclass(frozen=True)
class _Nominal:
    """The nominal file as read: its record, and a point set (3D), a 2D template (read_template's
    result) or a STEP model (engine.io.step.StepNominal, whose tessellation is the point set)."""

    record: InputRecord
    point_set: PointSet | None = None
    template: TemplateFile | None = None
    step: StepNominal | None = None
    plan_faces: dict | None = None
    """A QIF plan's regions matched to the STEP model's faces (JSON ``plan_faces``)."""

    @property
    def points3d(self) -> PointSet:
        """The point set of a 3D nominal; a 2D template has none (ValueError)."""
        if self.point_set is None:
            raise ValueError(f"the 2D template {self.record.path} has no 3D point set")
        return self.point_set

    def nominal3d(self, nominal: Nominal | None) -> Nominal:
        """``nominal``, the engine's nominal built from this 3D one; None only for a 2D
        template (ValueError)."""
        if nominal is None:
            raise ValueError(f"the 2D template {self.record.path} has no 3D nominal")
        return nominal


def _read_nominal(path: str, settings: InspectionSettings) -> _Nominal:
    sha = sha256_of(path)
    if is_template(path):
        from .io.templates import read_template

        tpl = read_template(path, layers=settings.layers, units=settings.units,
                            scale=settings.scale)
        return _Nominal(InputRecord("nominal", path, sha, None, tpl.template.n_primitives),
                        template=tpl)
    if formats.kind_of(path) == formats.STEP:
        from .io.step import read_step

        step = read_step(path)
        return _Nominal(InputRecord("nominal", path, sha, None, n_faces=step.n_faces),
                        point_set=dataclasses.replace(step.point_set,
                                                      groups=face_groups(step)), step=step)
    ps = load_point_set(path)
    if ps.dim != 3:
        raise InputError("the nominal has 2 columns (x y): a 2D nominal must be a contour "
                         "template (a .dxf drawing, or .dat airfoil ordinates with "
                         "--scale); a 3D nominal needs x y z", path)
    return _Nominal(InputRecord("nominal", path, sha, ps.n), point_set=ps)


def _inspect_template(tpl, measured_ps: PointSet, settings: InspectionSettings, plan):
    """A 2D template's inspection, and its plan's characteristics."""
    from .contour import ContourIndex

    index = ContourIndex(tpl.template)
    share = plan_share(plan)
    with within(0.0, 1.0 - share):
        result = _inspect_2d(tpl, index, measured_ps, settings, plan)
    if plan is None:
        return result
    from .gdt.characteristics import inspect_plan_2d

    with within(1.0 - share, 1.0):
        report("judging the plan's characteristics", 0.0)
        return inspect_plan_2d(result, plan, index, measured_ps.labels,
                               settings.zone_in_verdict)


PLAN_WEIGHT = 100
"""How many characteristics take about as long to judge as the registration takes (the seat
bracket: 100 of them on its five regions ~0.5 s, its registration ~0.3 s): the share of the
progress bar a plan's characteristics move it over (:func:`plan_share`). An estimate, as
every fraction of the bar is."""


def plan_share(plan: Plan | None) -> float:
    """The fraction of the run a plan's characteristics are expected to take (0 without one):
    n / (n + PLAN_WEIGHT) for n characteristics."""
    n = 0 if plan is None else len(plan.characteristics)
    return n / (n + PLAN_WEIGHT)


def _inspect_2d(tpl, index, measured_ps: PointSet, settings: InspectionSettings, plan):
    """The registration and judging of the measured points against a 2D template."""
    return inspect_2d(tpl.template, measured_ps.points, measured_ps.dim, settings.tolerance,
                      index=index, fit=settings.fit, decision_rule=settings.decision_rule,
                      instrument=instrument_of(settings.instrument, plan),
                      guard=settings.guard, seed=settings.seed,
                      template_facts={"units": tpl.units, "unitless": tpl.unitless,
                                      "flattened_curves": tpl.flattened,
                                      "ignored_entities": tpl.ignored})


def _inspect_3d(nominal: Nominal, source: _Nominal, measured_ps: PointSet,
                settings: InspectionSettings, plan, noise: float | None = None):
    """A 3D inspection (exact to a STEP model's faces when the nominal is one), and its plan's
    characteristics; ``noise``: the measurement's noise, mm, when the scene shows it (the
    spread of its table about its plane: engine.registration_types.RegistrationSettings)."""
    distances = None if source.step is None else ExactDistances(source.step, nominal)
    share = plan_share(plan)
    with within(0.0, 1.0 - share):
        result = inspect(nominal, measured_ps.points, settings.tolerance,
                         RegistrationSettings(noise_mm=noise, seed=settings.seed),
                         fit=settings.fit, decision_rule=settings.decision_rule, surface=distances,
                         instrument=instrument_of(settings.instrument, plan),
                         guard=settings.guard)
    if source.step is not None:
        facts = {"step": step_facts(source.step), "plan_faces": source.plan_faces}
        result = dataclasses.replace(result, extra={**result.extra, **{
            k: v for k, v in facts.items() if v is not None}})
    if plan is not None:
        from .gdt.characteristics import inspect_plan

        ps = source.points3d
        with within(1.0 - share, 1.0):
            report("judging the plan's characteristics", 0.0)
            result = inspect_plan(result, plan, nominal, ps.labels, measured_ps.points,
                                  measured_ps.labels, settings.zone_in_verdict, ps.groups,
                                  distances,
                                  None if distances is None else face_sample(distances),
                                  None if source.step is None else exact_features(source.step),
                                  None if distances is None else face_rivals(distances))
    if distances is not None and distances.missed:
        result = distances.judged(result, measured_ps.labels)
    return result
