"""Operators of thesis chapter 4: crest lines, feature-sensitive decimation, segmentation.

All three work on every selected mesh object in Object mode and on the edited objects in Edit mode
(one object per mesh datablock, as dgmesh.curvature_map; Crest Lines' curve object goes to every
selected linked duplicate), on the original mesh data (modifiers ignored). Everything is computed
before anything is written: an object that fails gets an ERROR report naming it and is left
untouched, the others are written. Started from the UI they run the native work in a worker thread
(jobs.NativeJobOperator): the status bar shows the progress and Esc cancels with nothing written.
The redo panel, scripts and ``--background`` use execute().
Quads and n-gons are read through Blender's loop triangles; n-gons whose triangulation has
zero-area or doubled ears (straight runs of corners, valence-2 vertices left by dissolving edges)
are re-triangulated (polymesh.repair_ngon_triangles) instead of being rejected.

dgmesh.decimate_features rewrites the mesh datablock in place (its name, materials and users stay;
in Edit mode it leaves and re-enters Edit mode around the write, and undo restores the old mesh).
It keeps: UV maps (per corner: a corner keeps its UV when its vertex survives, else it takes the
surviving vertex's UV on the same side of the seam; a vertex moved to its quadric optimum gets the
UV interpolated at its new position in the nearest original triangle), material index and smooth
flag per face (from the input face the output triangle was), UV seams and material borders
exactly (their vertices are locked), the seam and sharp flags, creases and bevel weights of edges
that survive, hidden faces'
hide flags, loose vertices and wire edges as they are (a wire edge follows the surface vertex
it hangs from), vertex groups and generic attributes (colours included: point data from the
vertex each output vertex was, blended like the UVs where it moved; face data from the input face;
edge data where the edge survives; corner data as the UVs), vertex creases and bevel weights, and
custom split normals (per corner as the UVs). It drops quads/n-gons (the result is triangles); it
refuses shape keys.

Crest-line fitting is cached per mesh content and ``rings``, so redo-panel changes of the threshold
or the marking flags only re-filter the traced lines.

The threshold is the strength T of thesis eq. 4.10, T = length * integral of the cyclideness
sqrt(e_max^2 + e_min^2) along the line: dimensionless (the same on a scaled copy), large for long
lines across strongly curved, non-cyclide regions. The thesis used T = 1..3 on its one-ring
figures (its own models and meshes). On CGAL's scans T = 5 still leaves many noise-driven
fragments on the bunny, T = 10 keeps the salient lines of fandisk, bunny and armadillo, T = 25
only the strongest (bench/images/crest_lines_*.png), hence the library's default of 10
(CrestOptions.threshold).

Property defaults are the library's (dgmesh/crest_lines.h, decimate.h, segment.h): DerivativeOptions
and CrestOptions for Crest Lines, decimate_feature_defaults() for Feature Decimate,
SegmentOptions and segment_feature_defaults() for Segment.
"""

import hashlib

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty

from .. import colors, polymesh
from ..crest import (MAX_FEATURE_WEIGHT, CrestOptions, DerivativeOptions, SegmentOptions, decimate_feature_defaults,
                     segment_feature_defaults)
from . import bridge, compat
from .common import (editable_collection, plural as _plural, poll_mesh_targets, read_only_reason,
                     report_shown_shape, target_objects)
from .jobs import NativeJobOperator
from .prefs import api

_get = bridge.get_array  # (collection, key, dtype[, width])

ATTR_RIDGE = "dg_ridge"
ATTR_VALLEY = "dg_valley"
ATTR_SEGMENT = "dg_segment"
ATTR_SEGMENT_COLOR = "dg_segment_color"
ATTR_SEGMENT_SEAMS = "dg_segment_seams"  # the seams Segment added (a re-run replaces them, keeps the user's)
RIDGE_RGB = (0.1, 0.25, 1.0)   # thesis figures: ridges blue ...
VALLEY_RGB = (1.0, 0.1, 0.1)   # ... valleys red
FIT_DEFAULTS = DerivativeOptions()  # property defaults: the library's own
CREST_DEFAULTS = CrestOptions()
DECIMATE_FEATURES = decimate_feature_defaults()
SEGMENT_DEFAULTS = SegmentOptions()
SEGMENT_FEATURES = segment_feature_defaults()
THRESHOLD_HELP = ("Keep crest lines whose strength T is at least this. T = line length x integral of "
                  "the cyclideness sqrt(e_max^2 + e_min^2) along the line (thesis eq. 4.10): "
                  "dimensionless, so it does not depend on the model's size; 0 keeps every line, "
                  "about 10 keeps the salient lines of typical scans")

FIT_CACHE = {}  # (mesh key, rings, jet) -> unfiltered CrestLines; a few entries only
FIT_CACHE_SIZE = 4


class _PerObjectJob(NativeJobOperator):
    """Reads every target object (main thread), computes each in the worker (an object's MeshError
    is recorded, Cancelled stops everything), writes the successful ones in finish()."""

    @classmethod
    def poll(cls, context):
        return poll_mesh_targets(cls, context)

    # Subclasses: read(obj) -> data (main thread); compute(data, params, progress) -> result
    # (worker thread: numpy and dgmesh only); write(context, obj, data, result) -> summary dict.
    def params(self):
        return {}

    def prepare(self, context):
        dg = api()
        items, failures = [], []
        for obj in target_objects(context):
            reason = read_only_reason(obj)
            if reason:
                failures.append((obj.name, reason))
                continue
            try:
                items.append((obj.name, self.read(obj)))
            except dg.MeshError as exc:
                failures.append((obj.name, str(exc)))
        params = self.params()
        compute = type(self).compute
        if not items:
            self._report_failures(failures)
            return None

        def work(progress):
            results = list(failures)
            n = len(items)
            for i, (name, data) in enumerate(items):
                try:
                    result = compute(data, params, lambda f, i=i: progress((i + f) / n))
                except dg.MeshError as exc:
                    results.append((name, str(exc)))
                else:
                    results.append((name, (data, result)))
            return results

        return work

    def _report_failures(self, failures):
        for name, message in failures:
            self.report({'ERROR'}, f"{self.bl_label} failed on '{name}': {message}")

    def finish(self, context, results):
        failures = [(n, r) for n, r in results if isinstance(r, str)]
        done = [(n, r) for n, r in results if not isinstance(r, str)]
        written, objects = [], []
        if done:
            with bridge.object_mode(context):
                for name, (data, result) in done:
                    obj = bpy.data.objects.get(name)
                    try:
                        if obj is None or obj.type != 'MESH':
                            raise RuntimeError("the object is gone")
                        if (len(obj.data.vertices), len(obj.data.polygons)) != data["counts"]:
                            raise RuntimeError("the mesh changed while it was computed")
                        written.append(self.write(context, obj, data, result))
                        objects.append(obj)
                    except Exception as exc:
                        failures.append((name, f"could not write: {type(exc).__name__}: {exc}"))
        self._report_failures(failures)
        if not written:
            return {'CANCELLED'}
        self.report({'INFO'}, self.summary(written))
        report_shown_shape(self, objects)
        return {'FINISHED'}


def _read(obj):
    # N-gons with straight runs of corners (dissolved edges) may triangulate into zero-area
    # triangles: re-triangulate those instead of rejecting the mesh.
    arrays = polymesh.repair_ngon_triangles(bridge.read_object(obj, edges=True))
    data = {"arrays": arrays, "counts": (len(obj.data.vertices), len(obj.data.polygons))}
    return data


def _mesh_key(arrays):
    h = hashlib.blake2b(digest_size=16)
    h.update(np.ascontiguousarray(arrays.V).tobytes())
    h.update(np.ascontiguousarray(arrays.F).tobytes())
    return h.hexdigest()


def cached_crest_lines(arrays, rings, progress=None, jet=FIT_DEFAULTS.jet):
    """Every traced line (threshold 0) of the mesh, from the cache when the mesh is unchanged."""
    dg = api()
    key = (_mesh_key(arrays), int(rings), bool(jet))
    lines = FIT_CACHE.get(key)
    if lines is None:
        lines = dg.crest_lines(arrays.V, arrays.F, rings=rings, jet=jet, threshold=0.0, progress=progress)
        if len(FIT_CACHE) >= FIT_CACHE_SIZE:
            FIT_CACHE.pop(next(iter(FIT_CACHE)))
        FIT_CACHE[key] = lines
    return lines


def _write_edge_bool(mesh, name, values):
    attr = mesh.attributes.get(name)
    if attr is not None and (attr.data_type != 'BOOLEAN' or attr.domain != 'EDGE'):
        mesh.attributes.remove(attr)
        attr = None
    if attr is None:
        mesh.attributes.new(name, 'BOOLEAN', 'EDGE')
    mesh.attributes[name].data.foreach_set("value", np.ascontiguousarray(values, dtype=bool))


def _or_edge_flag(mesh, prop, mask):
    """Sets a boolean edge flag (seam, sharp) on the masked edges, keeping the existing ones."""
    if prop == "sharp":
        cur = compat.element_values(mesh, "sharp_edge")
        compat.set_element_values(mesh, "sharp_edge", mask if cur is None else cur | mask)
        return
    cur = np.zeros(len(mesh.edges), bool)
    mesh.edges.foreach_get("use_seam", cur)
    mesh.edges.foreach_set("use_seam", cur | mask)


CURVE_KEY = "dgmesh_crest_lines_of"  # custom property of a crest-line curve: its mesh object


def _remove_curve_object(obj):
    """Removes the crest-line curve object made for ``obj`` (found by its pointer to ``obj``, which
    follows renames; files from before hold the '<object> Crest Lines' name)."""
    legacy = bpy.data.objects.get(f"{obj.name} Crest Lines")
    for old in [o for o in bpy.data.objects if o.type == 'CURVE' and (o.get(CURVE_KEY) == obj or
                                                                       (o == legacy and CURVE_KEY not in o))]:
        data = old.data
        bpy.data.objects.remove(old)
        if data.users == 0:
            bpy.data.curves.remove(data)


def _curve_objects(context, objects, lines):
    """(Re)creates '<object> Crest Lines' for each of ``objects`` (linked duplicates of one mesh),
    all sharing one curve: one poly spline per line, ridges blue, valleys red."""
    for obj in objects:
        _remove_curve_object(obj)
    curve = bpy.data.curves.new(f"{objects[0].name} Crest Lines", 'CURVE')
    curve.dimensions = '3D'
    curve.bevel_depth = 0.0
    for label, rgb in (("dg_ridge", RIDGE_RGB), ("dg_valley", VALLEY_RGB)):
        mat = bpy.data.materials.get(label) or bpy.data.materials.new(label)
        mat.diffuse_color = (*rgb, 1.0)
        curve.materials.append(mat)
    for poly, kind in zip(lines.polylines, lines.line_kind.tolist()):
        spline = curve.splines.new('POLY')
        spline.points.add(len(poly) - 1)
        co = np.ones((len(poly), 4), dtype=np.float32)
        co[:, :3] = poly
        spline.points.foreach_set("co", co.ravel())
        spline.material_index = int(kind)
    for obj in objects:
        cobj = bpy.data.objects.new(f"{obj.name} Crest Lines", curve)
        cobj[CURVE_KEY] = obj
        editable_collection(context, obj).objects.link(cobj)
        # A child with an identity local transform sits exactly on the mesh (a copied matrix_world
        # loses a parent's shear) and follows it when it moves.
        cobj.parent = obj


def _fit_name(fit, n_jet, n):
    """Which fit ran: the jet fit gives way to the thesis's on meshes that look noisy."""
    if fit != "JET":
        return "thesis fit"
    if n_jet == n:
        return "jet fit"
    if n_jet == 0:
        return "thesis fit: the mesh looks noisy" if n == 1 else "thesis fit: the meshes look noisy"
    return f"jet fit; thesis fit on {n - n_jet} of {n} meshes, which look noisy"


class DGMESH_OT_crest_lines(_PerObjectJob, bpy.types.Operator):
    bl_idname = "dgmesh.crest_lines"
    bl_label = "Crest Lines"
    bl_description = (
        "Detect ridges and valleys (crest lines, thesis ch. 4) of the selected meshes and mark the "
        "edges that follow them as edge attributes dg_ridge / dg_valley (optionally seams, sharp "
        "edges and a curve object). Lines are kept when their strength T (length x integrated "
        "cyclideness, scale independent) reaches the threshold"
    )
    bl_options = {'REGISTER', 'UNDO'}

    rings: IntProperty(name="Rings", description="Fitting neighbourhood (k-ring): larger ignores finer "
                       "features and gives smoother lines", default=FIT_DEFAULTS.rings, min=1, max=4)
    fit: EnumProperty(name="Fit", description="How the curvature derivatives are estimated", items=(
        ("JET", "Jet", "Two-pass jet fit: the more accurate derivatives and lines that do not depend on the "
         "triangulation; on a mesh that looks noisy, and on flat or constant-curvature regions (rounded edges), "
         "the thesis's fit is used"),
        ("THESIS", "Thesis", "The thesis's adjacent-normal cubic fit (eq. 4.7) everywhere: smoother, less "
         "accurate")), default="JET" if FIT_DEFAULTS.jet else "THESIS")
    threshold: FloatProperty(name="Threshold T", description=THRESHOLD_HELP, default=CREST_DEFAULTS.threshold,
                             min=0.0, soft_max=100.0)
    ridges: BoolProperty(name="Ridges", description="Convex crest lines", default=CREST_DEFAULTS.ridges)
    valleys: BoolProperty(name="Valleys", description="Concave crest lines", default=CREST_DEFAULTS.valleys)
    mark_seams: BoolProperty(name="Mark Seams", description="Also mark the edges as UV seams", default=False)
    mark_sharp: BoolProperty(name="Mark Sharp", description="Also mark the edges as sharp", default=False)
    create_curves: BoolProperty(name="Curve Object", description="Add a curve object '<object> Crest Lines' "
                                "with the exact polylines (ridges blue, valleys red)", default=False)

    def read(self, obj):
        return _read(obj)

    def params(self):
        return {"rings": self.rings, "jet": self.fit == "JET", "threshold": self.threshold, "ridges": self.ridges,
                "valleys": self.valleys}

    @staticmethod
    def compute(data, p, progress):
        arrays = data["arrays"]
        lines = cached_crest_lines(arrays, p["rings"], progress, jet=p["jet"]).filter(p["threshold"], p["ridges"],
                                                                                        p["valleys"])
        ridge, valley = polymesh.crest_edges(lines, arrays)
        return lines, ridge, valley

    def write(self, context, obj, data, result):
        dg = api()
        lines, ridge, valley = result
        mesh = obj.data
        if len(mesh.edges) != len(ridge):
            raise RuntimeError("the mesh changed while it was computed")
        _write_edge_bool(mesh, ATTR_RIDGE, ridge)
        _write_edge_bool(mesh, ATTR_VALLEY, valley)
        shown = ~_get(mesh.edges, "hide", bool)  # hidden edges are left alone, as Blender's own tools do
        if self.mark_seams:
            _or_edge_flag(mesh, "seam", (ridge | valley) & shown)
        if self.mark_sharp:
            _or_edge_flag(mesh, "sharp", (ridge | valley) & shown)
        mesh.update()
        # Linked duplicates share the mesh, so its marked edges, but each shows it in its own place:
        # every selected one gets its curve.
        owners = [obj] + [o for o in context.selected_objects if o != obj and o.data == mesh]
        if self.create_curves and len(lines):
            _curve_objects(context, owners, lines)
        elif self.create_curves:  # a run that finds no line leaves no stale curve behind
            for owner in owners:
                _remove_curve_object(owner)
        n_r = int((lines.line_kind == dg.crest.RIDGE).sum())
        return {"lines": len(lines), "ridges": n_r, "length": lines.total_length,
                "ridge_edges": int(ridge.sum()), "valley_edges": int(valley.sum()),
                "jet": int(lines.derivatives.jet_used),
                "curves": len(owners) if self.create_curves and len(lines) else 0}

    def summary(self, written):
        tot = {k: sum(w[k] for w in written) for k in written[0]}
        return (f"Crest lines on {_plural(len(written), 'object')}: {tot['lines']} lines ({tot['ridges']} ridges, "
                f"{tot['lines'] - tot['ridges']} valleys), total length {tot['length']:.4g}; marked "
                f"{tot['ridge_edges']} ridge and {tot['valley_edges']} valley edges "
                f"(threshold T {self.threshold:g}, rings {self.rings}, {_fit_name(self.fit, tot['jet'], len(written))})"
                # linked duplicates: one mesh computed, a curve object for each of them
                + (f"; curves for {tot['curves']} objects" if tot["curves"] > len(written) else "")
                + ("; Ridges and Valleys are both off" if not (self.ridges or self.valleys) else ""))


def _read_for_decimation(obj):
    """Triangles plus what decimation carries over: UV maps (per corner), material index and
    smooth flag per polygon."""
    data = _read(obj)
    mesh = obj.data
    n_loops, n_poly = len(mesh.loops), len(mesh.polygons)
    loop_vertex = np.empty(n_loops, dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", loop_vertex)
    uvs = []
    for layer in mesh.uv_layers:
        uv = np.empty(2 * n_loops, dtype=np.float32)
        layer.data.foreach_get("uv", uv)
        uvs.append((layer.name, uv.reshape(-1, 2)))
    mat = np.empty(n_poly, dtype=np.int32)
    mesh.polygons.foreach_get("material_index", mat)
    smooth = np.empty(n_poly, dtype=bool)
    mesh.polygons.foreach_get("use_smooth", smooth)
    # Vertices on UV seams (several UVs) or material borders are locked, so seams and borders stay
    # exact and every decimated face keeps corners of one UV island.
    loop_mat = np.repeat(mat, np.diff(np.append(_get(mesh.polygons, "loop_start", np.int32), n_loops)))
    locked = polymesh.locked_vertices(loop_vertex, len(mesh.vertices), [uv for _, uv in uvs], loop_mat)
    # Seams and sharp edges, carried over where their edges survive (_carry_edge_flags).
    edges = np.empty(2 * len(mesh.edges), dtype=np.int32)
    mesh.edges.foreach_get("vertices", edges)
    flags = {"seam": _get(mesh.edges, "use_seam", bool)}
    sharp = compat.element_values(mesh, "sharp_edge")
    if sharp is not None:
        flags["sharp"] = sharp
    # Edge creases and bevel weights, likewise.
    weights = {}
    for name in ("crease_edge", "bevel_weight_edge"):
        values = compat.element_values(mesh, name)
        if values is not None and values.any():
            weights[name] = values
    wire = np.ones(len(mesh.edges), bool)  # edges of no face
    wire[_get(mesh.loops, "edge_index", np.int32)] = False
    data.update(edges=edges.reshape(-1, 2), edge_flags=flags, edge_weights=weights,
                vertex_weights=_read_vertex_weights(mesh), wire=wire,
                hide=(_get(mesh.vertices, "hide", bool), _get(mesh.polygons, "hide", bool)))
    # A half modelled with a Mirror modifier: no face may end up lying in a mirror plane, where the
    # mirrored half puts its twin (the mirrored mesh would tear there).
    planes = polymesh.mirror_plane_bits(data["arrays"].V, bridge.mirror_axes(obj, data["arrays"].V)[0])
    data.update(loop_vertex=loop_vertex, uvs=uvs, material_index=mat, use_smooth=smooth, locked=locked, planes=planes,
                uv_active=mesh.uv_layers.active_index,
                uv_render=next((i for i, l in enumerate(mesh.uv_layers) if l.active_render), 0))
    # Generic attributes (colours included) and vertex groups: rebuilding the geometry clears them
    # (names too), so they are read here and written back for the new elements.
    uv_names = {name for name, _uv in uvs}  # Blender 3.5+ lists UV maps among the attributes
    attrs = []
    for domain in ('POINT', 'EDGE', 'FACE', 'CORNER'):
        for name, values in bridge.read_attributes(mesh, domain):
            if name not in uv_names:
                attrs.append((name, mesh.attributes[name].data_type, domain, values))
    colors = mesh.color_attributes
    # Custom split normals: carried per corner like the UVs (and set again after the rebuild).
    normals = compat.corner_normals(mesh) if mesh.has_custom_normals else None
    data.update(attributes=attrs, normals=normals, active_color=bridge.active_color_name(mesh),
                render_color=colors[colors.render_color_index].name if len(colors) else None,
                vertex_groups=bridge.read_vertex_groups(obj))
    return data


def _read_vertex_weights(mesh):
    """Vertex creases and bevel weights, {"crease_vert" / "bevel_weight_vert": values} where any is
    set."""
    out = {name: compat.element_values(mesh, name) for name in ("crease_vert", "bevel_weight_vert")}
    return {k: v for k, v in out.items() if v is not None and v.any()}


def _write_vertex_weights(mesh, weights, idx, w):
    """``_read_vertex_weights``' values on the decimated mesh: each output vertex takes the largest
    of its sources' (``polymesh.vertex_sources``, those with a weight), as merged edges do."""
    for name, values in weights.items():
        compat.set_element_values(mesh, name, polymesh.largest_source_values(values, idx, w))


def _surviving_edges(mesh, data, vertex_map):
    """(output edges, input edges) of the input edges that survive the decimation: both ends kept
    and still joined by an edge (vertices on UV seams are locked, so an unwrapped mesh keeps all its
    seams)."""
    return polymesh.surviving_edges(_get(mesh.edges, "vertices", np.int32, 2), len(mesh.vertices), data["edges"],
                                    vertex_map)


def _carry_edge_flags(mesh, data, edge_pairs):
    """Seams, sharp edges, creases and bevel weights of the input stay on the edges that survive."""
    out_e, in_e = edge_pairs
    for prop, flag in data["edge_flags"].items():
        mask = np.zeros(len(mesh.edges), bool)
        mask[out_e[flag[in_e]]] = True
        if mask.any():
            _or_edge_flag(mesh, prop, mask)
    for name, values in data["edge_weights"].items():
        new = np.zeros(len(mesh.edges), np.float32)
        np.maximum.at(new, out_e, values[in_e])  # input edges merged into one: the largest (as seams OR)
        compat.set_element_values(mesh, name, new)


def _write_decimated(obj, data, V2, F2, vertex_map, face_map, source_vertex):
    """Replaces the mesh's geometry in place (same datablock: its name, materials and users stay),
    with UV maps, generic attributes, vertex groups, material indices, smooth and hide flags, and
    loose geometry carried over."""
    mesh = obj.data
    arrays = data["arrays"]
    poly = arrays.tri_poly[face_map]
    moved = np.any(V2 != arrays.V[source_vertex], axis=1)
    uvs = []
    carried = (data["uvs"] or data["attributes"] or data["vertex_groups"] or data["vertex_weights"]
               or data["normals"] is not None)
    lookup = (polymesh.moved_vertex_lookup(arrays.tri_loops, arrays.V, arrays.F, V2, vertex_map, moved) if carried
              else None)

    plan = []  # polymesh.corner_plan, made for the first corner layer

    def corners(values):  # UVs and other corner values of the output triangles, (3 m2, k)
        if not plan:
            plan.append(polymesh.corner_plan(arrays.tri_loops, data["loop_vertex"], F2, face_map, source_vertex))
        return polymesh.decimated_corner_values(values, plan[0], lookup, moved, len(V2))

    for name, uv in data["uvs"]:
        uvs.append((name, corners(uv)))
    # Loose geometry (vertices and edges of no face) is not decimated but carried over, after the
    # surface's vertices; wire edges follow their ends.
    loose = np.flatnonzero(vertex_map < 0)
    vertex_map = vertex_map.copy()
    vertex_map[loose] = len(V2) + np.arange(len(loose))
    wire = polymesh.wire_edges(data["edges"], data["wire"], vertex_map)
    mesh.clear_geometry()
    mesh.vertices.add(len(V2) + len(loose))
    mesh.vertices.foreach_set("co", np.ascontiguousarray(np.vstack([V2, arrays.V[loose]]), dtype=np.float32).ravel())
    mesh.loops.add(3 * len(F2))
    mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(F2, dtype=np.int32).ravel())
    mesh.polygons.add(len(F2))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F2), 3, dtype=np.int32))
    compat.set_loop_totals(mesh, np.full(len(F2), 3, dtype=np.int32))
    mesh.polygons.foreach_set("material_index", data["material_index"][poly])
    mesh.polygons.foreach_set("use_smooth", data["use_smooth"][poly])
    mesh.update(calc_edges=True)
    if len(wire):
        ev = _get(mesh.edges, "vertices", np.int32, 2)
        wire = wire[polymesh.find_edges(polymesh.edge_lookup(ev, len(mesh.vertices)), wire) < 0]
        mesh.edges.add(len(wire))
        mesh.edges.foreach_set("vertices", np.concatenate([ev.ravel(), wire.astype(np.int32).ravel()]))
    edge_pairs = _surviving_edges(mesh, data, vertex_map)
    _carry_edge_flags(mesh, data, edge_pairs)
    # Hidden faces stay hidden, with the vertices and edges no shown face uses.
    vert_hide, poly_hide = data["hide"]
    if poly_hide.any() or vert_hide.any():
        hide = poly_hide[poly]
        shown = np.zeros(len(mesh.vertices), bool)
        shown[F2[~hide].ravel()] = True
        shown[len(V2):] = ~vert_hide[loose]
        ev = _get(mesh.edges, "vertices", np.int32, 2)
        mesh.polygons.foreach_set("hide", hide)
        mesh.vertices.foreach_set("hide", ~shown)
        mesh.edges.foreach_set("hide", ~(shown[ev[:, 0]] & shown[ev[:, 1]]))
    for name, uv in uvs:
        layer = mesh.uv_layers.new(name=name, do_init=False)
        layer.data.foreach_set("uv", np.ascontiguousarray(uv, dtype=np.float32).ravel())
    if len(mesh.uv_layers):
        mesh.uv_layers.active_index = min(max(data["uv_active"], 0), len(mesh.uv_layers) - 1)
        mesh.uv_layers[min(data["uv_render"], len(mesh.uv_layers) - 1)].active_render = True
    if data["normals"] is not None:
        normals = corners(data["normals"])
        normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
        compat.set_custom_normals(mesh, normals)
    idx, w = polymesh.vertex_sources(source_vertex, lookup, data["loop_vertex"], loose, len(V2))
    _write_attributes(mesh, data, idx, w, poly, edge_pairs, corners)
    if data["vertex_groups"] is not None:
        bridge.write_vertex_groups(obj, data["vertex_groups"], idx, w)
    _write_vertex_weights(mesh, data["vertex_weights"], idx, w)
    mesh.validate(verbose=False)
    mesh.update()
    bridge.remap_vertex_references(mesh, vertex_map)  # every input vertex went to one output vertex


def _write_attributes(mesh, data, idx, w, poly, edge_pairs, corners):
    """The input's generic attributes on the decimated mesh: point data blended by
    ``polymesh.vertex_sources``, face data from the input polygon each triangle was, edge data where the edge survives
    (new edges: zero), corner data as the UVs take theirs (``corners``); colours stay active."""
    out_e, in_e = edge_pairs
    for name, data_type, domain, values in data["attributes"]:
        if domain == 'POINT':
            new = polymesh.blend_attributes([(name, values)], idx, w)[0][1]
        elif domain == 'FACE':
            new = values[poly]
        elif domain == 'EDGE':
            new = np.zeros((len(mesh.edges), values.shape[1]), values.dtype)
            new[out_e] = values[in_e]
        else:
            new = corners(values)
        mesh.attributes.new(name, data_type, domain)
        key, _k, dtype = bridge.ATTRIBUTE_TYPES[data_type]
        mesh.attributes[name].data.foreach_set(key, np.ascontiguousarray(new, dtype=dtype).ravel())
    names = {a.name for a in mesh.color_attributes}
    active, render = data["active_color"], data["render_color"]
    if active in names:
        bridge.set_active_color(mesh, active, render=render if render in names else active)


class DGMESH_OT_decimate_features(_PerObjectJob, bpy.types.Operator):
    bl_idname = "dgmesh.decimate_features"
    bl_label = "Feature Decimate"
    bl_description = (
        "Quadric decimation of the selected meshes that keeps density near salient crest lines "
        "(thesis 4.8). The result is triangles; UV maps, material slots per face and smooth "
        "shading are carried over (vertices on UV seams and material borders are kept in place), "
        "seams, sharp edges, creases and bevel weights where their edges survive, vertex groups, "
        "vertex creases, custom normals, colour and other attributes, hidden faces, and loose "
        "vertices and edges as they are"
    )
    bl_options = {'REGISTER', 'UNDO'}

    ratio: FloatProperty(name="Ratio", description="Fraction of triangles to keep", default=0.1, min=0.001,
                         max=1.0, subtype='FACTOR')
    feature_weight: FloatProperty(name="Feature Weight", description="eta of thesis eq. 4.12: 0 is plain "
                                  "quadric decimation, larger keeps more triangles near crest lines",
                                  default=DECIMATE_FEATURES.feature_weight, min=0.0, max=MAX_FEATURE_WEIGHT, soft_max=10.0)
    rings: IntProperty(name="Rings", description="Fitting neighbourhood of the crest lines (k-ring)",
                       default=DECIMATE_FEATURES.rings, min=1, max=4)
    threshold: FloatProperty(name="Threshold T", description=THRESHOLD_HELP, default=DECIMATE_FEATURES.threshold,
                             min=0.0, soft_max=100.0)

    def read(self, obj):
        dg = api()
        mesh = obj.data
        if mesh.shape_keys is not None:
            raise dg.MeshError("the mesh has shape keys, which cannot follow a new vertex count (apply or remove "
                               "them first)")
        if self._edit_mode:
            # The whole mesh is rebuilt: in Edit mode only when all of it is shown and selected.
            if _get(mesh.polygons, "hide", bool).any() or not _get(mesh.polygons, "select", bool).all():
                raise dg.MeshError("Feature Decimate works on whole meshes: reveal and select all (Alt+H, A) "
                                   "or use it in Object mode")
        return _read_for_decimation(obj)

    def prepare(self, context):
        # UV layer data cannot be read from a mesh in Edit mode (3.4 has no loop data there): leave
        # Edit mode for the reads (that writes the edit-mesh to the mesh) and re-enter it.
        self._edit_mode = context.mode == 'EDIT_MESH'
        with bridge.object_mode(context):
            return super().prepare(context)

    def params(self):
        return {"ratio": self.ratio, "eta": self.feature_weight, "rings": self.rings, "threshold": self.threshold}

    @staticmethod
    def compute(data, p, progress):
        dg = api()
        arrays = data["arrays"]
        target = max(4, int(round(p["ratio"] * len(arrays.F))))
        lines = None
        if p["eta"] > 0:
            lines = cached_crest_lines(arrays, p["rings"], lambda f: progress(0.3 * f)).filter(p["threshold"])
        V2, F2, vmap, fmap, src = dg.decimate(arrays.V, arrays.F, target_faces=target, feature_weight=p["eta"],
                                              crest_lines=lines, return_map=True, return_face_map=True,
                                              locked=data["locked"], planes=data["planes"],
                                        progress=lambda f: progress((0.3 if lines is not None else 0.0) + 0.7 * f))
        return V2, F2, vmap, fmap, src, 0 if lines is None else len(lines)

    def write(self, context, obj, data, result):
        V2, F2, vmap, fmap, src, n_lines = result
        _write_decimated(obj, data, V2, F2, vmap, fmap, src)
        return {"before": len(data["arrays"].F), "after": len(F2), "lines": n_lines, "uv": len(data["uvs"]),
                "locked": int(data["locked"].sum())}

    def summary(self, written):
        tot = {k: sum(w[k] for w in written) for k in written[0]}
        return (f"Decimated {_plural(len(written), 'object')}: {tot['before']} -> {tot['after']} triangles "
                f"(feature weight {self.feature_weight:g}, {tot['lines']} crest lines; "
                f"{_plural(tot['uv'], 'UV map')}, materials, vertex groups and attributes carried over, "
                f"{tot['locked']} vertices on UV seams / material borders kept)")


class DGMESH_OT_segment(_PerObjectJob, bpy.types.Operator):
    bl_idname = "dgmesh.segment"
    bl_label = "Segment"
    bl_description = (
        "Split the selected meshes into nearly planar connected segments (variational shape "
        "approximation guided by crest lines, thesis 4.9): INT face attribute dg_segment, a colour "
        "per segment, optionally seams on segment borders"
    )
    bl_options = {'REGISTER', 'UNDO'}

    segments: IntProperty(name="Segments", default=SEGMENT_DEFAULTS.segments, min=1, soft_max=200)
    feature_weight: FloatProperty(name="Feature Weight", description="eta of thesis eq. 4.12: 0 is plain "
                                  "VSA, larger makes borders follow crest lines",
                                  default=SEGMENT_FEATURES.feature_weight, min=0.0, max=MAX_FEATURE_WEIGHT, soft_max=10.0)
    rings: IntProperty(name="Rings", description="Fitting neighbourhood of the crest lines (k-ring)",
                       default=SEGMENT_FEATURES.rings, min=1, max=4)
    threshold: FloatProperty(name="Threshold T", description=THRESHOLD_HELP, default=SEGMENT_FEATURES.threshold,
                             min=0.0, soft_max=100.0)
    mark_seams: BoolProperty(name="Mark Seams", description="Mark segment borders as UV seams", default=False)

    def read(self, obj):
        dg = api()
        data = _read(obj)
        if self.segments > len(obj.data.polygons):
            raise dg.MeshError(f"cannot make {self.segments} segments from {len(obj.data.polygons)} faces")
        return data

    def params(self):
        return {"segments": self.segments, "eta": self.feature_weight, "rings": self.rings,
                "threshold": self.threshold}

    @staticmethod
    def compute(data, p, progress):
        dg = api()
        arrays = data["arrays"]
        lines = None
        if p["eta"] > 0:
            lines = cached_crest_lines(arrays, p["rings"], lambda f: progress(0.3 * f)).filter(p["threshold"])
        labels = dg.segment(arrays.V, arrays.F, segments=p["segments"], feature_weight=p["eta"], crest_lines=lines,
                            progress=lambda f: progress((0.3 if lines is not None else 0.0) + 0.7 * f))
        return labels, 0 if lines is None else len(lines)

    def write(self, context, obj, data, result):
        tri_labels, n_lines = result
        arrays = data["arrays"]
        mesh = obj.data
        n_poly = len(mesh.polygons)
        # A polygon takes the label of its first triangle.
        labels = np.zeros(n_poly, dtype=np.int32)
        labels[arrays.tri_poly[::-1]] = tri_labels[::-1]
        n_seg = int(labels.max()) + 1 if n_poly else 0
        loop_poly = np.repeat(np.arange(n_poly), np.diff(np.append(
            _get(mesh.polygons, "loop_start", np.int32), len(mesh.loops))))
        loop_edge = _get(mesh.loops, "edge_index", np.int32)
        attr = mesh.attributes.get(ATTR_SEGMENT)
        if attr is not None and (attr.data_type != 'INT' or attr.domain != 'FACE'):
            mesh.attributes.remove(attr)
            attr = None
        if attr is None:
            mesh.attributes.new(ATTR_SEGMENT, 'INT', 'FACE')
        mesh.attributes[ATTR_SEGMENT].data.foreach_set("value", labels)
        # Flat colour per face: a face-corner colour attribute.
        rgba = colors.segment_colors(max(n_seg, 1))[labels[loop_poly]]
        cattr = mesh.attributes.get(ATTR_SEGMENT_COLOR)
        if cattr is not None and (cattr.data_type != 'FLOAT_COLOR' or cattr.domain != 'CORNER'):
            mesh.attributes.remove(cattr)
            cattr = None
        if cattr is None:
            mesh.color_attributes.new(ATTR_SEGMENT_COLOR, 'FLOAT_COLOR', 'CORNER')
        mesh.attributes[ATTR_SEGMENT_COLOR].data.foreach_set("color", rgba.ravel())
        bridge.set_active_color(mesh, ATTR_SEGMENT_COLOR)
        borders = 0
        if self.mark_seams:
            # An edge is a border when its corners belong to faces of different segments.
            lab = labels[loop_poly]
            lo = np.full(len(mesh.edges), np.iinfo(np.int32).max)
            hi = np.full(len(mesh.edges), -1)
            # Per edge, the smallest and largest label of its corners, reduced over the corners
            # grouped by edge (ufunc.at took 0.57 s at 1M triangles).
            if len(loop_edge):
                order = np.argsort(loop_edge, kind="stable")
                e, ls = loop_edge[order], lab[order]
                starts = np.r_[0, np.flatnonzero(np.diff(e)) + 1]
                lo[e[starts]] = np.minimum.reduceat(ls, starts)
                hi[e[starts]] = np.maximum.reduceat(ls, starts)
            hidden = _get(mesh.edges, "hide", bool)  # left alone, as Blender's own tools do
            border = (hi >= 0) & (lo != hi) & ~hidden
            borders = int(border.sum())
            seam = _get(mesh.edges, "use_seam", bool)
            ours = mesh.attributes.get(ATTR_SEGMENT_SEAMS)
            prev = np.zeros(len(seam), bool)
            if ours is not None and ours.domain == 'EDGE' and ours.data_type == 'BOOLEAN':
                prev = _get(ours.data, "value", bool)
            user = seam & ~prev  # the previous run's borders go, the user's seams stay
            kept = seam & hidden & prev  # ours on a hidden edge: left as it is, still ours
            mesh.edges.foreach_set("use_seam", user | border | kept)
            _write_edge_bool(mesh, ATTR_SEGMENT_SEAMS, (border & ~user) | kept)
        mesh.update()
        space = context.space_data
        if getattr(space, "type", None) == 'VIEW_3D' and space.shading.type == 'SOLID':
            space.shading.color_type = 'VERTEX'
        return {"segments": n_seg, "lines": n_lines, "borders": borders}

    def summary(self, written):
        tot = {k: sum(w[k] for w in written) for k in written[0]}
        text = (f"Segmented {_plural(len(written), 'object')} into {_plural(tot['segments'], 'segment')} "
                f"(feature weight {self.feature_weight:g}, {tot['lines']} crest lines)")
        if self.mark_seams:
            text += f"; {tot['borders']} border edges marked as seams"
        return text


classes = (DGMESH_OT_crest_lines, DGMESH_OT_decimate_features, DGMESH_OT_segment)
