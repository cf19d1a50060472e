# SPDX-License-Identifier: Apache-2.0
"""clvox Python binding (cffi, API mode). See python/README.md."""
import atexit
import math
import numbers
import os
import queue
import threading
import weakref

import numpy as np

from ._clvox import ffi, lib

__all__ = ["Context", "Mesh", "Volume", "Slab", "Error", "InvalidError", "CancelledError",
           "devices", "read", "read_info", "palettes", "version", "STATUS"]

# status value -> name: 0 "ok", 1 "invalid_argument", ..., 5 "mesh_invalid", ... (clvox.h)
STATUS = {int(getattr(lib, n)): n.replace("CLVOX_ERR_", "").replace("CLVOX_", "").lower() for n in dir(lib)
          if n.startswith("CLVOX_ERR_") or n == "CLVOX_OK"}

_CHANNELS = (("occupancy", lib.CLVOX_CHANNEL_OCCUPANCY), ("coverage", lib.CLVOX_CHANNEL_COVERAGE),
             ("element", lib.CLVOX_CHANNEL_ELEMENT), ("score", lib.CLVOX_CHANNEL_SCORE))
_METHODS = {"ray": lib.CLVOX_METHOD_RAY, "tetra": lib.CLVOX_METHOD_TETRA}
_MODES = {"solid": lib.CLVOX_MODE_SOLID, "surface": lib.CLVOX_MODE_SURFACE,
          "conservative": lib.CLVOX_MODE_CONSERVATIVE}
_INSIDE = {None: lib.CLVOX_INSIDE_DEFAULT, "winding": lib.CLVOX_INSIDE_WINDING,
           "winding-abs": lib.CLVOX_INSIDE_WINDING_ABS, "parity": lib.CLVOX_INSIDE_PARITY}
_WINDING_FIELDS = ("merged_vertices", "welded_vertices", "dropped_triangles", "components", "closed_components",
                   "cavities", "flipped_triangles", "nonmanifold_edges", "nonorientable_components",
                   "boundary_edges", "holes", "cap_triangles", "exact_points", "seconds")
_AXES = {None: lib.CLVOX_AXIS_DEFAULT, "x": lib.CLVOX_AXIS_X, "y": lib.CLVOX_AXIS_Y, "z": lib.CLVOX_AXIS_Z}
_METRICS = {"nearest": lib.CLVOX_METRIC_NEAREST, "outer": lib.CLVOX_METRIC_OUTER,
            "inner": lib.CLVOX_METRIC_INNER}
_COMPRESSIONS = {None: lib.CLVOX_COMPRESSION_DEFAULT, "none": lib.CLVOX_COMPRESSION_NONE,
                 "rle": lib.CLVOX_COMPRESSION_RLE, "zips": lib.CLVOX_COMPRESSION_ZIPS,
                 "zip": lib.CLVOX_COMPRESSION_ZIP, "piz": lib.CLVOX_COMPRESSION_PIZ}


def _out(ctype):
    """A new output struct (clvox_stats, clvox_volume_info, ...) with its
    .size set, as the library requires (clvox.h "Conventions")."""
    p = ffi.new(ctype + " *")
    p.size = ffi.sizeof(ctype)
    return p


def _fn(name):
    """A C function pointer to one of the binding's helpers (API mode needs addressof)."""
    return ffi.addressof(lib, name)


def version():
    """The C library's version string."""
    return ffi.string(lib.clvox_version()).decode()


# ---- errors -------------------------------------------------------------------

class Error(Exception):
    """A clvox failure: .status (int, clvox_status), .status_name ("mesh_invalid", ...),
    .message (the library's detail message)."""

    def __init__(self, status, message):
        self.status = int(status)
        self.status_name = STATUS.get(self.status, str(status))
        self.message = message
        text = ffi.string(lib.clvox_status_string(status)).decode()
        super().__init__(f"{message} ({text})" if message else text)


class InvalidError(Error, ValueError):
    """Bad input from the caller: invalid argument, mesh invalid/empty, bad grid, bad
    palette file. Also a ValueError."""


class CancelledError(Error):
    """The progress callback returned False (the run was cancelled, no file left)."""


_INVALID = {lib.CLVOX_ERR_INVALID_ARGUMENT, lib.CLVOX_ERR_MESH_INVALID, lib.CLVOX_ERR_MESH_EMPTY,
            lib.CLVOX_ERR_GRID, lib.CLVOX_ERR_MESH_FORMAT, lib.CLVOX_ERR_PALETTE_FORMAT}


# The library's messages are written for the CLI; these name the Python arguments instead.
_CLI_WORDS = (("give --box, --dims or --voxel-size", "give box=, dims= or voxel_size="),
              ("use --inside parity", "use inside='parity'"),
              ("take --compression none or the default", "take compression='none' or None, the default"),
              ("(no --compression)", "(no compression=)"),
              ("(choose one with --channel)", "(choose one with channels=)"),
              ("(--cube makes the box a cube around its centre; or give a cubic --box and -r N or --dims N,N,N)",
               "(cube=True makes the box a cube around its centre; or give a cubic box= and resolution=N or "
               "dims=(N, N, N))"),
              ("(use -r N, or --cube)", "(use resolution=N, or cube=True)"),
              ("(see clvox --list-devices)", "(see clvox.devices())"))


def _python_words(msg):
    for cli, py in _CLI_WORDS:
        msg = msg.replace(cli, py)
    return msg


def _error(status, ctx_ptr):
    msg = ffi.string(lib.clvox_context_error(ctx_ptr)).decode("utf-8", "replace") if ctx_ptr != ffi.NULL else ""
    msg = _python_words(msg)
    if status == lib.CLVOX_ERR_IO and "No such file" in msg:
        return FileNotFoundError(2, msg)
    if status == lib.CLVOX_ERR_OUT_OF_MEMORY:
        return MemoryError(msg)
    cls = InvalidError if status in _INVALID else CancelledError if status == lib.CLVOX_ERR_CANCELLED else Error
    return cls(status, msg)


# ---- devices ------------------------------------------------------------------

def _device(d):
    return {"index": int(d.index), "name": ffi.string(d.name).decode(), "platform": ffi.string(d.platform).decode(),
            "type": ffi.string(d.type).decode(), "version": ffi.string(d.version).decode(),
            "compute_units": int(d.compute_units), "global_mem_bytes": int(d.global_mem_bytes),
            "max_alloc_bytes": int(d.max_alloc_bytes), "fp64": bool(d.fp64),
            # a context's device: whether its kernels run in float (no fp64, float_kernels, or the
            # speed rule: double measured fp64_slowdown times slower, 8 or more; docs/design.md)
            "kernels_float": bool(d.kernels_float), "fp64_slowdown": float(d.fp64_slowdown)}


def devices():
    """OpenCL devices clvox can use, as dicts (index, name, platform, type, ...); [] when none."""
    count = ffi.new("size_t *")
    st = lib.clvox_list_devices(ffi.NULL, 0, count)
    if st == lib.CLVOX_ERR_NO_DEVICE or count[0] == 0:
        return []
    arr = ffi.new("clvox_device_info[]", count[0])
    arr[0].size = ffi.sizeof("clvox_device_info")  # and so the distance between entries
    st = lib.clvox_list_devices(arr, count[0], count)
    if st != lib.CLVOX_OK:
        raise Error(st, "clvox_list_devices failed")
    return [_device(arr[i]) for i in range(min(count[0], len(arr)))]


def palettes():
    """Names of the built-in palettes."""
    out, i = [], 0
    while True:
        p = lib.clvox_palette_builtin_name(i)
        if p == ffi.NULL:
            return out
        out.append(ffi.string(p).decode())
        i += 1


# ---- results --------------------------------------------------------------------

_REPORT_FIELDS = ("input_vertices", "input_faces", "polygons_triangulated", "vertices", "triangles",
                  "dropped_faces", "degenerate_triangles", "nonmanifold_faces", "boundary_edges",
                  "duplicate_triangles", "enclosed_volume")
_STATS_FIELDS = ("filled_voxels", "total_voxels", "rays", "odd_parity_rays", "overflow_rays", "max_crossings",
                 "quadtree_depth", "quadtree_leaves", "quadtree_refs", "slab_depth", "peak_slab_bytes",
                 "output_bytes", "samples_per_voxel", "coverage_sum", "palette_early_voxels",
                 "palette_shortcut_voxels", "palette_scored_voxels", "palette_nonempty_voxels", "palette_volume")
_STAGES = [ffi.string(lib.clvox_stage_name(i)).decode() for i in range(lib.CLVOX_STAGE_COUNT)]


def _report_dict(r):
    d = {f: getattr(r, f) for f in _REPORT_FIELDS}
    d["closed"] = bool(r.closed)
    d["bbox_min"] = tuple(r.bbox_min)
    d["bbox_max"] = tuple(r.bbox_max)
    return d


def _stats_dict(s):
    d = {f: getattr(s, f) for f in _STATS_FIELDS}
    d["channels"] = [n for n, bit in _CHANNELS if s.channels & bit]
    d["seconds"] = {_STAGES[i]: s.seconds[i] for i in range(lib.CLVOX_STAGE_COUNT)}
    d["inside"] = ffi.string(lib.clvox_inside_name(s.inside)).decode()
    d["winding"] = ({f: getattr(s.winding, f) for f in _WINDING_FIELDS}
                    if s.inside in (lib.CLVOX_INSIDE_WINDING, lib.CLVOX_INSIDE_WINDING_ABS) else None)
    if d["winding"] is not None:  # the certified crack weld (docs/design.md "Cracks"), as --json has it
        d["winding"]["crack_weld"] = ({"distance": float(s.crack_weld_distance),
                                       "welded_vertices": int(s.crack_welded_vertices),
                                       "pairs": int(s.crack_pairs), "holes_left": int(s.crack_holes)}
                                      if s.crack_pairs else None)
        d["winding"]["host_points"] = int(s.winding_host_points)  # float devices: decided on the host
    d["devices"] = [{"index": int(e.device), "slabs": int(e.slabs), "slices": int(e.slices),
                     "busy_s": float(e.busy_seconds), "discarded_slabs": int(e.discarded_slabs),
                     "failed": bool(e.failed), "left_out": bool(e.left_out)}
                    for e in (s.devices[i] for i in range(s.device_count))]
    d["scheduling_efficiency"] = float(s.scheduling_efficiency)
    return d


class _GridMixin:
    def to_world(self, index):
        """World coordinates (x, y, z) of voxel centres. `index`: integer array (..., 3) in
        array order (z, y, x), as np.argwhere(vol.occupancy) gives."""
        idx = np.asarray(index, dtype=np.float64)
        if idx.shape[-1:] != (3,):
            raise ValueError("index must have shape (..., 3), in array order (z, y, x)")
        o = np.asarray(self.origin)
        h = np.asarray(self.voxel_size)
        return o + (idx[..., ::-1] + 0.5) * h

    def index_of(self, points):
        """Array indices (z, y, x) (int64, shape (..., 3)) of the voxels holding world points
        (x, y, z) (..., 3); voxel (i, j, k) covers [origin + (i,j,k) h, origin + (i+1,j+1,k+1) h).
        Points outside the grid give indices outside [0, shape)."""
        p = np.asarray(points, dtype=np.float64)
        if p.shape[-1:] != (3,):
            raise ValueError("points must have shape (..., 3), as (x, y, z)")
        ijk = np.floor((p - np.asarray(self.origin)) / np.asarray(self.voxel_size)).astype(np.int64)
        return ijk[..., ::-1]

    @property
    def shape(self):
        """(Z, Y, X): the arrays' shape; dims is (X, Y, Z)."""
        return (self.dims[2], self.dims[1], self.dims[0])


class Volume(_GridMixin):
    """A voxel volume in memory. Arrays have shape (Z, Y, X), C order, so
    vol.occupancy[k, j, i] is voxel (i, j, k) (x fastest, as in the library and the EXR file):
      occupancy  bool   (binary runs, thresholded coverage, or when asked for)
      coverage   float32 in [0, 1] (oversampled runs), exactly inside/samples
      element    uint16 (palette runs; 0 empty, 1 full)
      score      float32 in [0, 1] (palette runs)
    Channels a run did not produce are None. dims (X, Y, Z), origin (corner of voxel 0,0,0) and
    voxel_size are tuples in x, y, z order. stats / report are dicts (None for clvox.read)."""

    def __init__(self, dims, origin, voxel_size, occupancy=None, coverage=None, element=None, score=None,
                 stats=None, report=None, info=None):
        self.dims = tuple(int(d) for d in dims)
        self.origin = tuple(float(v) for v in origin)
        self.voxel_size = tuple(float(v) for v in voxel_size)
        self.occupancy, self.coverage, self.element, self.score = occupancy, coverage, element, score
        self.stats, self.report, self.info = stats, report, info

    @property
    def channels(self):
        return [n for n, _ in _CHANNELS if getattr(self, n) is not None]

    def __repr__(self):
        return (f"<clvox.Volume {self.dims[0]}x{self.dims[1]}x{self.dims[2]} (X,Y,Z) "
                f"channels={','.join(self.channels)} voxel_size={self.voxel_size}>")


class Slab:
    """Slices z0 .. z0+nz-1 of a run: arrays of shape (nz, Y, X) (None for a channel not produced)."""

    def __init__(self, z0, occupancy, coverage, element, score):
        self.z0 = z0
        self.occupancy, self.coverage, self.element, self.score = occupancy, coverage, element, score

    @property
    def nz(self):
        for a in (self.occupancy, self.coverage, self.element, self.score):
            if a is not None:
                return a.shape[0]
        return 0

    def __repr__(self):
        return f"<clvox.Slab z0={self.z0} nz={self.nz}>"


# ---- meshes ---------------------------------------------------------------------

class Mesh:
    """A validated triangle mesh owned by the library (loaded once, voxelized many times).
    Made by Context.mesh(); .report is the library's mesh report as a dict."""

    def __init__(self, ptr, source):
        self._ptr = ffi.gc(ptr, lib.clvox_mesh_destroy)
        self.source = source
        self.report = _report_dict(lib.clvox_mesh_get_report(self._ptr))

    def close(self):
        if self._ptr is not None:
            ffi.release(self._ptr)
            self._ptr = None

    def __repr__(self):
        r = self.report
        return f"<clvox.Mesh {r['triangles']} triangles, {r['vertices']} vertices, closed={r['closed']}>"


def _scene_arrays(scene):
    """A trimesh.Scene flattened as clvox flattens a glTF or 3MF scene: every
    node that places a geometry contributes that geometry's triangles moved by
    the node's world transform (scene.graph[node] -> (matrix, geometry name)),
    so a geometry placed by two nodes appears twice; geometries without faces
    (paths, point clouds) are left out. Computed in float64."""
    vs, fs, base = [], [], 0
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        g = scene.geometry.get(name)
        faces = getattr(g, "faces", None)
        if g is None or faces is None or len(faces) == 0:
            continue
        m = np.asarray(transform, dtype=np.float64)
        v = np.asarray(g.vertices, dtype=np.float64) @ m[:3, :3].T + m[:3, 3]
        vs.append(v)
        fs.append(np.asarray(faces, dtype=np.int64) + base)
        base += len(v)
    if not vs:
        raise ValueError("the scene holds no triangles")
    return np.concatenate(vs), np.concatenate(fs)


def _as_arrays(vertices, faces):
    """(V, 3) float32 and (F, 3) uint32 C-contiguous arrays, copying only when the input is not
    already such (one copy at most: dtype and layout are changed together)."""
    v = np.asarray(vertices)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"vertices must have shape (V, 3), got {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3:
        raise ValueError(f"faces must have shape (F, 3) (triangles), got {f.shape}")
    if v.dtype.kind != "f":
        raise ValueError(f"vertices must be floating point (float32 or float64), got {v.dtype}")
    if f.dtype.kind not in "iu":
        raise ValueError(f"faces must be integer (int32, int64, uint32, ...), got {f.dtype}")
    if f.size and f.dtype != np.uint32:
        lo, hi = int(f.min()), int(f.max())
        if lo < 0:
            raise ValueError(f"faces: negative vertex index {lo}")
        if hi > 0xFFFFFFFF:
            raise ValueError(f"faces: vertex index {hi} does not fit in 32 bits")
    v = np.ascontiguousarray(v, dtype=np.float32)
    f = np.ascontiguousarray(f, dtype=np.uint32)
    return v, f


# ---- arguments ------------------------------------------------------------------
# Numbers are checked here, naming the Python argument: cffi would raise OverflowError for a
# negative value and silently truncate 32.5 to 32; bool is not a number here.

_U32 = 0xFFFFFFFF
_U64 = 0xFFFFFFFFFFFFFFFF


def _int_arg(name, value, lo, hi=_U32):
    """An integer argument (int or numpy integer) in [lo, hi] (hi None: no upper bound)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    v = int(value)
    if v < lo:
        raise ValueError(f"{name} must be >= {lo}, got {v}")
    if hi is not None and v > hi:
        raise ValueError(f"{name} must be <= {hi}, got {v}")
    return v


def _float_arg(name, value, lo=None, positive=False):
    """A finite real argument (int, float or a numpy number), >= lo, or > 0 when positive."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    if positive and not v > 0:
        raise ValueError(f"{name} must be > 0, got {v}")
    if lo is not None and v < lo:
        raise ValueError(f"{name} must be >= {lo}, got {v}")
    return v


def _cubic_or_none(v):
    """None, a number, or a sequence of three equal values (voxel_size/dims that allow a cube)."""
    if v is None or isinstance(v, (numbers.Real, np.number)):
        return True
    try:
        t = list(np.asarray(v).reshape(-1))
    except (ValueError, TypeError):
        return True  # _grid_options says what is wrong with it
    return len(t) == 3 and t[0] == t[1] == t[2]


def _seq_arg(name, value, n, what):
    """The items of a sequence of n values (a tuple, list or 1-D array), for name's checks."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or not hasattr(value, "__iter__"):
        raise TypeError(f"{name} must be {what}, got {value!r}")
    items = list(np.asarray(value, dtype=object).reshape(-1)) if isinstance(value, np.ndarray) else list(value)
    if len(items) != n:
        raise ValueError(f"{name} must be {what}, got {value!r}")
    return items


# ---- context --------------------------------------------------------------------

class _Run:
    """State of one library call seen from the progress callback."""

    def __init__(self, progress):
        self.progress = progress
        self.exc = None
        self.c = ffi.new("pyclvox_run *")
        self.handle = ffi.new_handle(self)
        self.c.handle = self.handle
        self.c.call_python = 1
        self.done = threading.Event()  # set when the library call has returned


def _progress_onerror(exc_type, exc_value, tb):
    # an exception in pyclvox_py_progress (KeyboardInterrupt from Ctrl-C, or the user's callback
    # raising): keep it, cancel the run, raise it once the library has cleaned up.
    run = _current_run.get(threading.get_ident())
    if run is not None and run.exc is None:
        run.exc = exc_value if exc_value is not None else exc_type()
    return 0


_current_run = {}


@ffi.def_extern(onerror=_progress_onerror)
def pyclvox_py_progress(handle, fraction):
    run = ffi.from_handle(handle)
    if run.progress is not None and run.progress(fraction) is False:
        return 0
    return 1


def _channels_mask(channels):
    if channels is None:
        return 0
    if isinstance(channels, str):
        channels = [c.strip() for c in channels.split(",") if c.strip()]
    names = dict(_CHANNELS)
    mask = 0
    for c in channels:
        if c not in names:
            raise ValueError(f"unknown channel {c!r} (occupancy, coverage, element, score)")
        mask |= names[c]
    return mask


def _choice(table, value, what):
    try:
        return table[value]
    except (KeyError, TypeError):
        raise ValueError(f"{what} must be one of {', '.join(str(k) for k in table if k is not None)}, "
                         f"got {value!r}") from None


def _batch_output(template, mesh, n):
    """The output path of mesh number n for a batch template ({stem} {name} {dir} {n} {{ }})."""
    name = os.path.basename(mesh)
    dot = name.rfind(".")
    stem = name[:dot] if dot > 0 else name
    fields = {"stem": stem, "name": name, "dir": os.path.dirname(mesh) or ".", "n": str(n)}
    out, j = [], 0
    while j < len(template):
        c = template[j]
        if template.startswith("{{", j) or template.startswith("}}", j):
            out.append(c)
            j += 2
        elif c == "{":
            end = template.find("}", j)
            key = template[j + 1:end] if end > j else None
            if key not in fields:
                raise ValueError(f"output template {template!r}: unknown field at {template[j:]!r} "
                                 "(fields: {stem} {name} {dir} {n}; {{ and }} for braces)")
            out.append(fields[key])
            j = end + 1
        elif c == "}":
            raise ValueError(f"output template {template!r}: a lone '}}' (write }}}} for a brace)")
        else:
            out.append(c)
            j += 1
    return "".join(out)


class Context:
    """An OpenCL device with clvox's kernels built, kept for many calls.

    device: None (CLVOX_DEVICE, else "auto": first GPU, else first CPU device), "gpu", "cpu",
    an index from clvox.devices(), or a substring of the device or platform name; or several
    devices at once: "all", "0,1", or a list such as [0, "gpu"] (every call then spreads its
    slabs over them, same voxels; .devices lists them, .warnings says who was left out).
    host_only=True opens no device (reading volumes, loading meshes).
    float_kernels=True builds the kernels without double precision on every device (as devices
    without fp64 always get them): the same voxels in every mode; faster where double is slow
    (clvox --float-kernels).

    Thread safety: a Context runs one call at a time; a second call made while one is running
    (from another thread, or inside a slab iterator's loop) raises RuntimeError. Use one
    Context per thread; calls on different contexts run in parallel (the GIL is released
    while the library works)."""

    def __init__(self, device=None, host_only=False, float_kernels=False):
        from . import _pocl
        if _pocl.POCL_ERROR and not host_only:  # the wheel's PoCL would fail every kernel build
            raise Error(lib.CLVOX_ERR_KERNEL_BUILD, _pocl.POCL_ERROR)
        opts = ffi.new("clvox_context_options *")
        opts.size = ffi.sizeof("clvox_context_options")
        if isinstance(device, (list, tuple)):
            if not device or any(isinstance(e, (bool, np.bool_)) or not isinstance(e, (str, numbers.Integral, np.integer))
                                 for e in device):
                raise TypeError(f"device list must hold names or indices, got {device!r}")
            device = ",".join(str(_int_arg("device", e, 0)) if not isinstance(e, str) else e for e in device)
        if isinstance(device, (bool, np.bool_)) or not (device is None or isinstance(device, (str, numbers.Integral,
                                                                                           np.integer))):
            raise TypeError(f"device must be None, a name or an index from clvox.devices(), got {device!r}")
        if device is not None and not isinstance(device, str):
            device = _int_arg("device", device, 0)
        dev = None if device is None else str(device).encode()
        keep = ffi.new("char[]", dev) if dev is not None else ffi.NULL
        opts.device = keep
        opts.host_only = 1 if host_only else 0
        opts.float_kernels = 1 if float_kernels else 0
        out = ffi.new("clvox_context **")
        st = lib.clvox_context_create(opts, out)
        if st != lib.CLVOX_OK:
            err = _error(st, out[0])
            lib.clvox_context_destroy(out[0])
            raise err
        self._ptr = ffi.gc(out[0], lib.clvox_context_destroy)
        self._lock = threading.Lock()
        self.host_only = bool(host_only)
        d = lib.clvox_context_device(self._ptr)
        self.device = _device(d) if d != ffi.NULL and not host_only else None
        self.devices = [_device(lib.clvox_context_device_at(self._ptr, i))
                        for i in range(lib.clvox_context_device_count(self._ptr))]

    @property
    def warnings(self):
        """The library's warnings of the context's creation and its latest call, one string each
        (a device of a set left out or failed); [] when none."""
        if self._ptr is None:
            return []
        text = ffi.string(lib.clvox_context_warnings(self._ptr)).decode("utf-8", "replace")
        return [line for line in text.split("\n") if line]

    def close(self):
        """Releases the device now (otherwise when the Context is garbage collected)."""
        with self._busy():
            if self._ptr is not None:
                ffi.release(self._ptr)
                self._ptr = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        return f"<clvox.Context {self.device['name'] if self.device else 'host only'}>"

    # -- internals --
    class _Busy:
        def __init__(self, ctx):
            self.ctx = ctx

        def __enter__(self):
            if not self.ctx._lock.acquire(blocking=False):
                raise RuntimeError("this clvox.Context is running another call (use one Context per thread; "
                                   "a slab iterator holds its Context until it is exhausted or closed)")
            if self.ctx._ptr is None:
                self.ctx._lock.release()
                raise ValueError("the clvox.Context is closed")

        def __exit__(self, *exc):
            self.ctx._lock.release()

    def _busy(self):
        return Context._Busy(self)

    def _check(self, st):
        if st != lib.CLVOX_OK:
            raise _error(st, self._ptr)

    def _mesh(self, mesh):
        if isinstance(mesh, Mesh):
            return mesh
        out = ffi.new("clvox_mesh **")
        if isinstance(mesh, (str, bytes, os.PathLike)):
            path = os.fsencode(mesh)
            st = lib.clvox_mesh_load(self._ptr, path, out)
            self._check(st)
            return Mesh(out[0], os.fsdecode(path))
        if isinstance(mesh, tuple) and len(mesh) == 2:
            vertices, faces = mesh
        elif hasattr(mesh, "graph") and hasattr(mesh, "geometry"):   # trimesh.Scene
            vertices, faces = _scene_arrays(mesh)
        elif hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
            vertices, faces = mesh.vertices, mesh.faces
        else:
            raise TypeError("mesh must be a path, a (vertices, faces) tuple, an object with .vertices and "
                            ".faces (trimesh.Trimesh), a trimesh.Scene, or a clvox.Mesh")
        v, f = _as_arrays(vertices, faces)
        st = lib.clvox_mesh_from_arrays(self._ptr, ffi.from_buffer("float[]", v), v.shape[0],
                                        ffi.from_buffer("uint32_t[]", f), f.shape[0], out)
        self._check(st)
        return Mesh(out[0], "arrays")

    @staticmethod
    def _grid_options(resolution, dims, voxel_size, box, pad, cube=False):
        g = ffi.new("clvox_grid_options *")
        g.size = ffi.sizeof("clvox_grid_options")
        given = [n for n, v in (("resolution", resolution), ("dims", dims), ("voxel_size", voxel_size))
                 if v is not None]
        if len(given) > 1:
            raise ValueError(f"give only one of resolution, dims and voxel_size (got {' and '.join(given)})")
        if resolution is not None:
            g.resolution = _int_arg("resolution", resolution, 1)
        if dims is not None:
            g.dims = tuple(_int_arg("dims", x, 1) for x in _seq_arg("dims", dims, 3, "(X, Y, Z)"))
        if voxel_size is not None:
            if isinstance(voxel_size, (numbers.Real, np.number)) or (isinstance(voxel_size, np.ndarray)
                                                                    and voxel_size.ndim == 0):
                vs = (voxel_size,) * 3
            else:
                vs = _seq_arg("voxel_size", voxel_size, 3, "a number or (sx, sy, sz)")
            g.voxel_size = tuple(_float_arg("voxel_size", x, positive=True) for x in vs)
        if box is not None:
            what = "(x0, y0, z0, x1, y1, z1) or ((x0, y0, z0), (x1, y1, z1))"
            try:
                flat = np.asarray(box, dtype=object).reshape(-1)
            except (ValueError, TypeError):
                raise ValueError(f"box must be {what}, got {box!r}") from None
            b = [_float_arg("box", x) for x in _seq_arg("box", flat, 6, what)]
            for a in range(3):
                if b[a + 3] < b[a]:
                    raise ValueError(f"box: the maximum {b[a + 3]} is below the minimum {b[a]} on axis {'xyz'[a]}")
            g.use_box = 1
            g.box_min = tuple(b[:3])
            g.box_max = tuple(b[3:])
        g.padding = _int_arg("pad", pad, 0)
        if not isinstance(cube, (bool, np.bool_)):
            raise TypeError(f"cube must be True or False, got {cube!r}")
        g.cube = 1 if cube else 0
        return g

    def _options(self, run, *, mode="solid", method="ray", axis=None, oversample=None, stochastic=False, seed=0,
                 threshold=None, channels=None, palette=None, metric="nearest", no_early_out=False,
                 shortcut=None, slab_depth=0, depth=0, leaf=0, compression=None, threads=0, inside=None,
                 weld=0.0):
        o = ffi.new("clvox_voxelize_options *")
        o.size = ffi.sizeof("clvox_voxelize_options")
        o.mode = _choice(_MODES, mode, "mode")
        o.method = _choice(_METHODS, method, "method")
        o.ray_axis = _choice(_AXES, axis, "axis")
        o.compression = _choice(_COMPRESSIONS, compression, "compression")
        o.metric = _choice(_METRICS, metric, "metric")
        o.inside = _choice(_INSIDE, inside, "inside")
        o.weld = _float_arg("weld", weld, lo=0.0)
        if oversample is not None:
            if isinstance(oversample, (tuple, list, np.ndarray)):
                n, m = (_int_arg("oversample", x, 1) for x in _seq_arg("oversample", oversample, 2, "K or (N, M)"))
            else:
                n = m = _int_arg("oversample", oversample, 1)
            o.oversample, o.oversample_points = n, m
        o.stochastic = 1 if stochastic else 0
        o.seed = _int_arg("seed", seed, 0, _U64)
        if threshold is not None:
            t = _float_arg("threshold", threshold)
            if not 0 <= t <= 1:
                raise ValueError(f"threshold must be in [0, 1], got {t}")
            o.threshold_set, o.threshold = 1, t
        o.channels = _channels_mask(channels)
        o.palette_no_early_out = 1 if no_early_out else 0
        if shortcut is not None:
            o.nearest_shortcut = 1
            if not (isinstance(shortcut, str) and shortcut == "auto"):
                o.shortcut_alpha, o.shortcut_beta = (_float_arg("shortcut", x) for x in
                                                     _seq_arg("shortcut", shortcut, 2, '"auto" or (alpha, beta)'))
        o.slab_depth = _int_arg("slab_depth", slab_depth, 0)
        o.quadtree_max_depth = _int_arg("depth", depth, 0)
        o.quadtree_leaf_size = _int_arg("leaf", leaf, 0)
        o.threads = _int_arg("threads", threads, 0)
        o.progress = _fn('pyclvox_progress')
        o.progress_user = run.c
        pal = None
        if palette is not None:
            pal = self._palette(palette)
            o.palette = pal
        return o, pal

    def _palette(self, palette):
        out = ffi.new("clvox_palette **")
        name = os.fsencode(palette)
        if name.decode(errors="replace") in palettes():
            st = lib.clvox_palette_builtin(self._ptr, name, out)
        else:
            st = lib.clvox_palette_load(self._ptr, name, out)
        self._check(st)
        return ffi.gc(out[0], lib.clvox_palette_destroy)

    def _call(self, run, fn, *args):
        tid = threading.get_ident()
        _current_run[tid] = run
        with _live_mu:
            _live_calls.add(run)
        try:
            st = fn(*args)  # cffi releases the GIL for the call
        finally:
            _current_run.pop(tid, None)
            with _live_mu:
                _live_calls.discard(run)
            run.done.set()
        if run.exc is not None:
            raise run.exc
        if st == lib.CLVOX_ERR_CANCELLED and run.c.out_of_memory:
            raise MemoryError("clvox: out of memory for the result arrays")
        self._check(st)

    def _prepare(self, mesh, resolution, dims, voxel_size, box, pad, progress, kw, cube=False):
        if self.host_only:
            raise RuntimeError("a host_only Context can not voxelize")
        if progress is not None and not callable(progress):
            raise TypeError(f"progress must be None or a function f(fraction), got {progress!r}")
        g = self._grid_options(resolution, dims, voxel_size, box, pad, cube)  # arguments first, then the mesh
        run = _Run(progress)
        opts, pal = self._options(run, **kw)
        m = self._mesh(mesh)
        rep = lib.clvox_mesh_get_report(m._ptr)
        grid = ffi.new("clvox_grid *")
        self._check(lib.clvox_grid_compute(self._ptr, g, rep.bbox_min, rep.bbox_max, grid))
        return m, grid, run, opts, pal

    # -- public --
    def mesh(self, mesh):
        """Loads (path: OBJ, OFF, PLY, STL, OM) or copies ((V, F) arrays, or an object with
        .vertices and .faces) and validates a mesh once, for several voxelize calls."""
        with self._busy():
            return self._mesh(mesh)

    def voxelize(self, mesh, *, resolution=None, dims=None, voxel_size=None, box=None, pad=0, cube=False,
                 progress=None, **options):
        """Voxelizes `mesh` into a Volume in memory (arrays of shape (Z, Y, X)).

        mesh: a path, (vertices (V,3) float, faces (F,3) int), an object with .vertices/.faces
        (trimesh), or a clvox.Mesh. Vertices are used as float32 (as clvox_mesh_from_arrays
        takes them); OFF/OBJ paths are read in double by the library.
        Grid (at most one of resolution / dims / voxel_size; none: resolution 256):
          resolution=N, dims=(X, Y, Z), voxel_size=s or (sx, sy, sz),
          box=(x0, y0, z0, x1, y1, z1) replaces the mesh's bounding box, pad=N empty voxels,
          cube=True makes the box a cube around its centre first (binvox's grid; the CLI's --cube):
          every edge as long as the longest, so resolution=N gives N x N x N voxels.
        Options (as the CLI's): mode="solid"|"surface"|"conservative", method="ray"|"tetra",
          axis=None|"x"|"y"|"z", oversample=K or (N, M), stochastic=False, seed=0,
          threshold=None|T, channels=None|"occupancy,coverage"|[...], palette=None|name|path,
          metric="nearest"|"outer"|"inner", no_early_out, shortcut=None|"auto"|(a, b),
          inside=None (winding)|"winding"|"winding-abs"|"parity", weld=0.0,
          slab_depth, depth, leaf, threads.
        progress: None or f(fraction) -> False to cancel (CancelledError); called from this
          thread at most ~10 times a second. Ctrl-C raises KeyboardInterrupt (main thread)."""
        with self._busy():
            m, grid, run, opts, pal = self._prepare(mesh, resolution, dims, voxel_size, box, pad, progress, options,
                                                    cube)
            X, Y, Z = grid.dims
            run.c.X, run.c.Y, run.c.Z = X, Y, Z
            stats = _out("clvox_stats")
            try:
                self._call(run, lib.clvox_voxelize_slabs, self._ptr, m._ptr, grid, opts,
                           _fn('pyclvox_slab_to_dense'), run.c, stats)
            except BaseException:
                for name in ("occupancy", "coverage", "element", "score"):
                    p = getattr(run.c, name)
                    if p != ffi.NULL:
                        lib.free(p)
                raise
            arrays = {}
            for name, ctype, dtype in (("occupancy", "uint8_t", np.bool_), ("coverage", "float", np.float32),
                                       ("element", "uint16_t", np.uint16), ("score", "float", np.float32)):
                p = getattr(run.c, name)
                if p == ffi.NULL:
                    arrays[name] = None
                    continue
                owned = ffi.gc(p, lib.free)  # the array's buffer keeps the malloc'd block alive
                n = X * Y * Z * np.dtype(dtype).itemsize
                arrays[name] = np.frombuffer(ffi.buffer(owned, n), dtype=dtype).reshape(Z, Y, X)
            del pal
            return Volume(grid.dims, grid.origin, grid.voxel_size, stats=_stats_dict(stats),
                          report=dict(m.report), **arrays)

    def voxelize_to_file(self, mesh, path, *, format=None, npy_bits=False, float32=False, uint32=False,
                         resolution=None, dims=None, voxel_size=None, box=None, pad=0, cube=None, progress=None,
                         **options):
        """Streams the volume to `path` through clvox_voxelize_to_file, the CLI's writer: the
        same file as `clvox MESH -o path` with the same options. format=None takes it from the
        extension (.exr .npy .nrrd .binvox .vdb, any case), else "exr"|"npy"|"nrrd"|"binvox"|"vdb"; an
        unknown extension raises ValueError (clvox.InvalidError) before any work.
        npy only: npy_bits=True packs occupancy 8 voxels per byte along x (--npy-bits),
        float32=True writes coverage/score as float32 (--npy-float32), uint32=True element as
        uint32 (--npy-uint32). npy and NRRD write one file per channel (OUT.npy, OUT.coverage.npy,
        ...; npy also OUT.json). compression=None|"none"|"rle"|"zips"|"zip"|"piz" (EXR; NRRD:
        "none" raw, default gzip). Memory: a slab (binvox: the volume as bits). Returns the
        stats dict. A failure, cancel or Ctrl-C leaves no file. cube=None: cube=True for binvox
        unless box=, dims or voxel sizes that differ per axis ask for another grid (as the CLI)."""
        p = os.fsencode(path)
        oo = ffi.new("clvox_output_options *")
        oo.size = ffi.sizeof("clvox_output_options")
        if format is not None:
            f = lib.clvox_format_from_name(str(format).encode()) if isinstance(format, str) else lib.CLVOX_FORMAT_AUTO
            if f == lib.CLVOX_FORMAT_AUTO:
                raise ValueError(f"format must be one of exr, npy, nrrd, binvox, vdb, got {format!r}")
            oo.format = f
        if cube is None:
            fmt = oo.format if oo.format != lib.CLVOX_FORMAT_AUTO else lib.clvox_format_from_path(p)
            cube = fmt == lib.CLVOX_FORMAT_BINVOX and box is None and _cubic_or_none(dims) and \
                _cubic_or_none(voxel_size)
        oo.flags = ((lib.CLVOX_OUTPUT_PACK_BITS if npy_bits else 0) | (lib.CLVOX_OUTPUT_FLOAT32 if float32 else 0) |
                    (lib.CLVOX_OUTPUT_UINT32 if uint32 else 0))
        with self._busy():
            m, grid, run, opts, pal = self._prepare(mesh, resolution, dims, voxel_size, box, pad, progress, options,
                                                    cube)
            stats = _out("clvox_stats")
            self._call(run, lib.clvox_voxelize_to_file, self._ptr, m._ptr, grid, opts, oo, p, stats)
            del pal
            d = _stats_dict(stats)
            d["report"] = dict(m.report)
            return d

    def iter_slabs(self, mesh, *, resolution=None, dims=None, voxel_size=None, box=None, pad=0, cube=False,
                   progress=None, prefetch=1, **options):
        """Yields Slab objects (z0 and (nz, Y, X) arrays) in increasing z while the library runs
        in a worker thread, for volumes larger than memory: at most `prefetch` slabs wait
        in the queue. Leaving the loop early (break, an exception, close(), or dropping the
        iterator) cancels the run and frees the Context; so does the end of the interpreter.
        The Context is busy until the iterator is exhausted, closed or dropped. The grid is the
        iterator's .grid attribute ((X, Y, Z), origin, voxel_size) once created."""
        return _SlabIterator(self, mesh, dict(resolution=resolution, dims=dims, voxel_size=voxel_size, box=box,
                                              pad=pad, cube=cube), progress, prefetch, options)

    def batch(self, meshes, output="{stem}.exr", *, shard=None, skip_existing=False, **options):
        """Voxelizes a list of meshes into files, as `clvox batch` does: `output` is a template
        with {stem} (file name without extension), {name}, {dir} (the mesh's directory, "." if
        none), {n} (the mesh's position in the whole list) and {{ }}; its folders are created.
        shard=(i, n) runs only the meshes whose position k has k % n == i, like --shard I/N, so
        that n processes or cluster tasks share a list with no coordination and the file names
        do not depend on n. skip_existing=True skips a mesh whose output exists (a failed or
        cancelled run leaves none, so a rerun resumes). Other keywords go to voxelize_to_file.
        Returns one dict per mesh of the shard: n, input, output, status ("ok", "skipped",
        "failed"), error (the message, or None) and stats (ok runs). A mesh that fails does not
        stop the others; CancelledError and KeyboardInterrupt do."""
        meshes = [os.fspath(m) for m in meshes]
        if shard is None:
            shard = (0, 1)
        try:
            i, n = (int(v) for v in shard)
        except (TypeError, ValueError):
            raise ValueError(f"shard must be (i, n) with 0 <= i < n, got {shard!r}") from None
        if not 0 <= i < n:
            raise ValueError(f"shard must be (i, n) with 0 <= i < n, got {shard!r}")
        outs = [_batch_output(output, m, k) for k, m in enumerate(meshes)]
        seen = {}
        for k, o in enumerate(outs):  # every shard's: shards run at once
            key = os.path.normpath(os.path.abspath(o))
            if key in seen:
                raise ValueError(f"meshes {seen[key]} and {k} would both write {o!r}: add {{n}} or {{dir}} "
                                 "to the output template")
            seen[key] = k
        results = []
        for k, m in enumerate(meshes):
            if k % n != i:
                continue
            r = {"n": k, "input": m, "output": outs[k], "status": "ok", "error": None, "stats": None}
            if skip_existing and os.path.exists(outs[k]):
                r["status"] = "skipped"
            else:
                folder = os.path.dirname(outs[k])
                try:
                    if folder:
                        os.makedirs(folder, exist_ok=True)
                    r["stats"] = self.voxelize_to_file(m, outs[k], **options)
                except CancelledError:
                    raise
                except (Error, OSError) as e:
                    r["status"], r["error"] = "failed", str(e)
            results.append(r)
        return results

    def read(self, path, channels=None):
        """Reads a clvox volume (EXR, npy, NRRD, binvox, .vdb) into a Volume; see clvox.read."""
        with self._busy():
            return _read(self._ptr, path, channels)


class _SlabRun:
    """The worker side of one iter_slabs run: the worker thread, the queue and the Context's
    lock. It holds no reference to its _SlabIterator, so an iterator that is dropped without
    close() (a `break`, an exception, `del`) is freed at once and its finalizer cancels the
    run, waits for the worker and frees the Context."""
    DONE = object()

    def __init__(self, ctx, m, grid_c, run, opts, pal, prefetch):
        self.ctx, self.m, self.grid_c, self.run, self.opts, self.pal = ctx, m, grid_c, run, opts, pal
        self.queue = queue.Queue(maxsize=prefetch)
        self.closed = False
        self.status = None
        self.stats = None
        self._released = False
        self._mu = threading.Lock()
        self.handle = ffi.new_handle(self)
        self.thread = threading.Thread(target=self._work, daemon=True, name="clvox.iter_slabs")

    def start(self):
        with _live_mu:
            _live_runs.add(self)
        try:
            self.thread.start()
        except BaseException:
            with _live_mu:
                _live_runs.discard(self)
            raise

    def _work(self):
        stats = _out("clvox_stats")
        try:
            st = lib.clvox_voxelize_slabs(self.ctx._ptr, self.m._ptr, self.grid_c, self.opts,
                                          _fn('pyclvox_py_slab'), self.handle, stats)
            self.status = st
            self.stats = _stats_dict(stats)
        except BaseException as e:  # pragma: no cover - defensive
            self.status = e
        finally:
            self.put(self.DONE)
            with _live_mu:
                _live_runs.discard(self)
            if self.closed:  # abandoned: nobody takes DONE, the worker frees the Context itself
                self.release()

    def put(self, item):
        """Queues a slab (or DONE); False once the run is closed (the consumer is gone)."""
        while not self.closed:
            try:
                self.queue.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def release(self):
        """Frees the Context's lock, once."""
        with self._mu:
            if self._released:
                return
            self._released = True
        self.ctx._lock.release()

    def cancel(self):
        """Stops the run and frees the Context: the library sees the cancel at its next slab
        or progress poll; this waits for the worker unless it is the worker's own thread (a
        finalizer run by the garbage collector there), which then frees the Context itself."""
        self.run.c.cancel = 1
        self.closed = True
        if self.thread.ident is None:  # never started
            self.release()
            return
        if threading.current_thread() is self.thread:
            return
        while self.thread.is_alive():
            try:  # empty the queue: a worker waiting to put a slab goes on, and sees the cancel
                while True:
                    self.queue.get_nowait()
            except queue.Empty:
                pass
            self.thread.join(timeout=0.005)
        self.release()


_live_runs = set()  # iter_slabs runs whose worker has not ended
_live_calls = set()  # _Run of library calls in progress (voxelize, voxelize_to_file), any thread
_live_mu = threading.Lock()


@atexit.register
def _cancel_live_runs():
    # At exit, before the interpreter is torn down: a library call still going in another
    # (daemon) thread would call back into a finalizing interpreter (a crash), so cancel
    # each run and wait for it. A cancelled run stops at the library's next poll; the C
    # progress trampoline sees the flag without entering Python.
    with _live_mu:
        runs, calls = list(_live_runs), list(_live_calls)
    for r in calls:
        r.c.cancel = 1
    for w in runs:
        w.cancel()
    for r in calls:
        r.done.wait(60)  # a bound only against a library that never polls; runs stop in well under 1 s


class _SlabIterator:
    """What Context.iter_slabs returns: consumes the worker's queue. Dropping it (break, an
    exception, del) cancels the run like close()."""

    def __init__(self, ctx, mesh, grid_kw, progress, prefetch, options):
        prefetch = _int_arg("prefetch", prefetch, 1)
        if not ctx._lock.acquire(blocking=False):
            raise RuntimeError("this clvox.Context is running another call (use one Context per thread; "
                               "a slab iterator holds its Context until it is exhausted or closed)")
        try:
            if ctx._ptr is None:
                raise ValueError("the clvox.Context is closed")
            m, grid, run, opts, pal = ctx._prepare(mesh, grid_kw["resolution"], grid_kw["dims"],
                                                   grid_kw["voxel_size"], grid_kw["box"], grid_kw["pad"],
                                                   progress, options, grid_kw["cube"])
            run.c.call_python = 0  # the worker thread gets no signals; the consumer sees them
            w = _SlabRun(ctx, m, grid, run, opts, pal, prefetch)
            w.start()
        except BaseException:
            ctx._lock.release()
            raise
        self._w = w
        self._progress = progress
        self.dims = tuple(grid.dims)
        self.origin = tuple(grid.origin)
        self.voxel_size = tuple(grid.voxel_size)
        self.grid = (self.dims, self.origin, self.voxel_size)
        self.stats = None
        self.status = None
        self.closed = False
        self._finalizer = weakref.finalize(self, _SlabRun.cancel, w)

    def __iter__(self):
        return self

    def __next__(self):
        if self.closed:
            raise StopIteration
        w = self._w
        while True:
            try:
                item = w.queue.get(timeout=0.1)  # a timeout, so that Ctrl-C is seen here
                break
            except queue.Empty:
                continue
        if item is _SlabRun.DONE:
            self.closed = True
            self._finalizer.detach()
            w.thread.join()
            w.release()
            self.stats, self.status = w.stats, w.status
            st = w.status
            if isinstance(st, BaseException):
                raise st
            if st != lib.CLVOX_OK:
                raise _error(st, w.ctx._ptr)
            raise StopIteration
        if self._progress is not None and self._progress((item.z0 + item.nz) / self.dims[2]) is False:
            self.close()
            raise CancelledError(lib.CLVOX_ERR_CANCELLED, "cancelled by the progress callback")
        return item

    def close(self):
        """Cancels the run (if still going) and frees the Context."""
        if self.closed:
            return
        self.closed = True
        self._finalizer()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


@ffi.def_extern()
def pyclvox_py_slab(user, slab):
    w = ffi.from_handle(user)
    if w.closed or w.run.c.cancel:
        return 1
    X, Y = w.grid_c.dims[0], w.grid_c.dims[1]
    nz = slab.nz
    n = X * Y * nz

    def take(ptr, ctype, dtype):
        if ptr == ffi.NULL:
            return None
        return np.frombuffer(ffi.buffer(ffi.cast(ctype + " *", ptr), n * np.dtype(dtype).itemsize),
                             dtype=dtype).reshape(nz, Y, X).copy()

    s = Slab(int(slab.z0), take(slab.occupancy, "uint8_t", np.bool_), take(slab.coverage, "float", np.float32),
             take(slab.element, "uint16_t", np.uint16), take(slab.score, "float", np.float32))
    return 0 if w.put(s) else 1


# ---- reading volumes --------------------------------------------------------------

def _info_dict(info):
    s = lambda a: ffi.string(a).decode("utf-8", "replace")  # noqa: E731
    return {"dims": tuple(info.dims), "origin": tuple(info.origin), "voxel_size": tuple(info.voxel_size),
            "method": s(info.method), "parameters": s(info.parameters), "version": s(info.version),
            "compression": s(info.compression), "channels": [c for c in s(info.channels).split(",") if c],
            "palette": s(info.palette), "palette_count": int(info.palette_count),
            "palette_hash": int(info.palette_hash), "metric": s(info.metric)}


def _read_header(ctx_ptr, p):
    info = _out("clvox_volume_info")
    # A missing-channel read fills the header and stops (read_exr.c documents this).
    st = lib.clvox_volume_read_slices(ctx_ptr, p, b"\x01", info, _fn('pyclvox_slice_probe'), ffi.NULL)
    if st != lib.CLVOX_ERR_EXR or info.dims[0] == 0:
        if st != lib.CLVOX_OK:
            raise _error(st, ctx_ptr)
    return info


def _read(ctx_ptr, path, channels=None):
    p = os.fsencode(path)
    info = _read_header(ctx_ptr, p)
    d = _info_dict(info)
    have = d["channels"]
    want = have if channels is None else ([channels] if isinstance(channels, str) else list(channels))
    X, Y, Z = d["dims"]
    arrays = {}
    for name in want:
        if name not in have:
            raise ValueError(f"{os.fsdecode(p)!r} has no channel {name!r} (has: {', '.join(have)})")
        buf = np.empty((Z, Y, X), dtype=np.float32)
        run = ffi.new("pyclvox_run *")
        run.X, run.Y, run.Z = X, Y, Z
        run.read_dest = ffi.from_buffer("float[]", buf)
        st = lib.clvox_volume_read_slices(ctx_ptr, p, name.encode(), ffi.NULL, _fn('pyclvox_slice_to_dense'), run)
        if st != lib.CLVOX_OK:
            raise _error(st, ctx_ptr)
        if name == "occupancy":
            buf = buf > 0.5
        elif name == "element":
            buf = buf.astype(np.uint16)
        if name in ("occupancy", "coverage", "element", "score"):
            arrays[name] = buf
    return Volume(d["dims"], d["origin"], d["voxel_size"], info=d, **arrays)


_host = threading.local()


def _host_ctx():
    """A host_only Context per thread, for clvox.read / read_info."""
    ctx = getattr(_host, "ctx", None)
    if ctx is None:
        ctx = _host.ctx = Context(host_only=True)
    return ctx


def batch(meshes, output="{stem}.exr", *, shard=None, skip_existing=False, device=None, **options):
    """Context(device).batch(...): voxelizes a list of meshes into files, with shard=(i, n)
    and skip_existing as `clvox batch --shard I/N --skip-existing`; see Context.batch."""
    with Context(device=device) as ctx:
        return ctx.batch(meshes, output, shard=shard, skip_existing=skip_existing, **options)


def read(path, channels=None):
    """Reads a clvox volume file into a Volume: EXR, npy (+ its .json), NRRD, binvox or .vdb
    (told by the first bytes; docs/formats.md "Reading volumes back"): arrays (Z, Y, X) for each channel
    (or only `channels`): occupancy bool (> 0.5), coverage/score float32 (the file's HALF
    values), element uint16; .info has the header (method, parameters, palette, ...).
    Needs no OpenCL device."""
    ctx = _host_ctx()
    with ctx._busy():
        return _read(ctx._ptr, path, channels)


def read_info(path):
    """A clvox volume's header as a dict (dims, origin, voxel_size, channels, method, ...)."""
    ctx = _host_ctx()
    with ctx._busy():
        return _info_dict(_read_header(ctx._ptr, os.fsencode(path)))
