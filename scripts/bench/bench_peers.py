#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Times two other solid voxelizers on the meshes and grids of scripts/bench/bench.sh.

Usage: /usr/bin/python3 scripts/bench/bench_peers.py [--quick] [--repeat R] [--timeout S] [--tsv FILE] [MESH:N ...]
       (default cases: armadillo at 128..1024, armadillo_s2/_s3, bunny00, cow at 512)

--timeout S: a case (one child process) running longer than S seconds is
killed and reported as skipped (default: no limit); a peer that timed out
on a mesh is not run on that mesh at a larger N.
--tsv FILE: also append one tab-separated record per case to FILE:
peer, mesh, triangles, N, grid, seconds, CPU seconds, peak RSS MB, inside
voxels (or peer, mesh, -, N, and "skipped >S s" / "failed").

Each (peer, mesh, N) runs in a fresh child process, so that "peak RSS" is
that case's own: VmHWM of the child, which includes the Python interpreter,
numpy and the imported library (VTK: the 3 vtkmodules used, ~55 MB;
pyopenvdb ~125 MB, mostly its shared libraries) before any work.
With --repeat R each case runs R times (R processes): the best time and the
largest peak RSS are reported (timings on a shared 2-core VM vary by 30 %).
"seconds" is wall time inside the child from opening the mesh file to a
dense occupancy volume in memory (numpy uint8/bool, one byte per voxel);
module import time is not counted, no file is written. "CPU seconds" is
user+system time of the process over the same interval: on a loaded machine
it is the steadier figure (for 1-thread VTK it is the uncontended time).

Grid: the same as clvox -r N: h = longest bounding-box extent / N, origin =
bbox min, ceil(extent / h) voxels (at least 1) on the other axes, voxel
(i,j,k) sampled at its centre origin + (i+0.5, j+0.5, k+0.5) h.

Mesh loading (shared by both peers, counted in their time): OFF is parsed
with numpy from the whole text (polygons fan-triangulated), binary PLY with
numpy.frombuffer; ASCII PLY is not supported here.

What each peer computes:
 - vtk: vtkPolyDataToImageStencil (VTK 9.1, python3-vtk9) with the voxel
   centres as its sample points, then vtkImageStencilToImage to a dense
   uint8 image (1 inside, 0 outside). The stencil is built per (y,z) row by
   cutting the polygons with the slice planes and filling between the
   crossings along x: an even-odd rule on the voxel centres, like clvox's
   parity. Limited to 1 thread (vtkMultiThreader global maximum 1;
   the stencil source is single-threaded anyway).
 - openvdb: pyopenvdb.FloatGrid.createLevelSetFromPolygons (OpenVDB 10,
   python3-openvdb; tools::meshToVolume) with a transform whose voxel (i,j,k)
   centre is the clvox voxel centre, default narrow band halfWidth 3: a
   signed distance narrow band plus a sign flood fill that marks interior
   tiles negative. The dense volume is then copyToArray in slabs of 16
   x-planes into a float32 buffer and thresholded (value < 0 -> inside) into
   a dense bool array. OpenVDB uses TBB threads: all cores (2 here).
Both report the number of inside voxels so they can be compared with the
"filled voxels" line of clvox (they differ slightly at the surface: VTK
rasterizes slice contours, OpenVDB's sign is from a distance field).
"""
import os
import resource
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
DEFAULT_CASES = [
    ("data/meshes/armadillo.off", 128), ("data/meshes/armadillo.off", 256),
    ("data/meshes/armadillo.off", 512), ("data/meshes/armadillo.off", 1024),
    ("data/meshes/armadillo_s2.ply", 512), ("data/meshes/armadillo_s3.ply", 512),
    ("data/meshes/bunny00.off", 512), ("data/meshes/cow.off", 512),
]
QUICK_CASES = [("data/meshes/armadillo.off", 128), ("data/meshes/armadillo.off", 256),
               ("data/meshes/cow.off", 256)]
PEERS = ("vtk", "openvdb")


def load_mesh(path):
    """Returns (points float64 (n,3), triangles int64 (m,3))."""
    import numpy as np
    with open(path, "rb") as f:
        data = f.read()
    if path.lower().endswith(".off"):
        lines = [ln.split(b"#", 1)[0] for ln in data.split(b"\n")]
        lines = [ln for ln in lines if ln.strip()]
        head = lines[0].split()
        if not head[0].endswith(b"OFF"):
            raise ValueError("not an OFF file: " + path)
        rest = head[1:]
        first = 1
        if not rest:
            rest = lines[1].split()
            first = 2
        nv, nf = int(rest[0]), int(rest[1])
        pts = np.array(b" ".join(lines[first:first + nv]).split(), dtype=np.float64).reshape(nv, 3)
        faces = lines[first + nv:first + nv + nf]
        try:  # fast path: all triangles
            f = np.array(b" ".join(faces).split(), dtype=np.int64).reshape(nf, 4)
            if (f[:, 0] != 3).any():
                raise ValueError
            tris = f[:, 1:4]
        except ValueError:
            tl = []
            for ln in faces:
                v = [int(x) for x in ln.split()]
                n = v[0]
                for k in range(2, n):
                    tl.append((v[1], v[k], v[k + 1]))
            tris = np.array(tl, dtype=np.int64)
        return pts, tris
    if path.lower().endswith(".ply"):
        end = data.index(b"end_header") + len(b"end_header")
        end = data.index(b"\n", end) + 1
        header = data[:end].decode("ascii").split("\n")
        if "format binary_little_endian 1.0" not in header:
            raise ValueError("only binary little-endian PLY is supported: " + path)
        nv = nf = 0
        for ln in header:
            t = ln.split()
            if t[:2] == ["element", "vertex"]:
                nv = int(t[2])
            elif t[:2] == ["element", "face"]:
                nf = int(t[2])
        # Layout written by scripts/bench/subdivide.c: float x,y,z; list uchar int.
        pts = np.frombuffer(data, dtype="<f4", count=nv * 3, offset=end).reshape(nv, 3).astype(np.float64)
        rec = np.frombuffer(data, dtype=np.dtype([("n", "u1"), ("v", "<i4", (3,))]),
                            count=nf, offset=end + nv * 12)
        if (rec["n"] != 3).any():
            raise ValueError("non-triangle faces in " + path)
        return pts, rec["v"].astype(np.int64)
    raise ValueError("unsupported mesh format: " + path)


def grid_for(pts, n):
    import math
    lo = pts.min(axis=0)
    ext = pts.max(axis=0) - lo
    h = float(ext.max()) / n
    dims = []
    for a in range(3):
        if ext[a] == ext.max():
            dims.append(n)
        else:
            dims.append(max(1, min(n, int(math.ceil(float(ext[a]) / h)))))
    return [float(x) for x in lo], h, dims


def run_vtk(path, n):
    import numpy as np
    from vtkmodules import vtkCommonCore, vtkCommonDataModel, vtkImagingStencil
    from vtkmodules.util import numpy_support as ns
    vtkCommonCore.vtkMultiThreader.SetGlobalMaximumNumberOfThreads(1)
    t0 = time.perf_counter()
    pts, tris = load_mesh(path)
    lo, h, dims = grid_for(pts, n)
    poly = vtkCommonDataModel.vtkPolyData()
    p = vtkCommonCore.vtkPoints()
    p.SetData(ns.numpy_to_vtk(pts, deep=1))
    poly.SetPoints(p)
    cells = vtkCommonDataModel.vtkCellArray()
    offsets = np.arange(0, 3 * len(tris) + 1, 3, dtype=np.int64)
    cells.SetData(ns.numpy_to_vtkIdTypeArray(offsets, deep=1),
                  ns.numpy_to_vtkIdTypeArray(np.ascontiguousarray(tris.reshape(-1)), deep=1))
    poly.SetPolys(cells)
    st = vtkImagingStencil.vtkPolyDataToImageStencil()
    st.SetInputData(poly)
    st.SetOutputOrigin(lo[0] + 0.5 * h, lo[1] + 0.5 * h, lo[2] + 0.5 * h)
    st.SetOutputSpacing(h, h, h)
    st.SetOutputWholeExtent(0, dims[0] - 1, 0, dims[1] - 1, 0, dims[2] - 1)
    st.SetTolerance(0.0)
    img = vtkImagingStencil.vtkImageStencilToImage()
    img.SetInputConnection(st.GetOutputPort())
    img.SetInsideValue(1)
    img.SetOutsideValue(0)
    img.SetOutputScalarTypeToUnsignedChar()
    img.Update()
    out = img.GetOutput()
    vol = ns.vtk_to_numpy(out.GetPointData().GetScalars())  # dense uint8, x fastest
    t1 = time.perf_counter()
    return t1 - t0, len(tris), dims, int(np.count_nonzero(vol))


def run_openvdb(path, n):
    import numpy as np
    import pyopenvdb as vdb
    t0 = time.perf_counter()
    pts, tris = load_mesh(path)
    lo, h, dims = grid_for(pts, n)
    xf = vdb.createLinearTransform([[h, 0, 0, 0], [0, h, 0, 0], [0, 0, h, 0],
                                    [lo[0] + 0.5 * h, lo[1] + 0.5 * h, lo[2] + 0.5 * h, 1]])
    grid = vdb.FloatGrid.createLevelSetFromPolygons(
        pts.astype(np.float32), triangles=tris.astype(np.uint32), transform=xf,
        halfWidth=vdb.LEVEL_SET_HALF_WIDTH)
    vol = np.empty(dims, dtype=bool)  # [i][j][k] = voxel (i,j,k)
    slab = 16
    buf = np.empty((slab, dims[1], dims[2]), dtype=np.float32)
    for x0 in range(0, dims[0], slab):
        s = min(slab, dims[0] - x0)
        b = buf[:s]
        grid.copyToArray(b, ijk=(x0, 0, 0))
        np.less(b, 0.0, out=vol[x0:x0 + s])
    t1 = time.perf_counter()
    return t1 - t0, len(tris), dims, int(np.count_nonzero(vol))


def peak_rss_mb():
    """VmHWM of this process image (reset at exec, unlike ru_maxrss)."""
    try:
        with open("/proc/self/status") as f:
            for ln in f:
                if ln.startswith("VmHWM:"):
                    return int(ln.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def child(peer, path, n):
    fn = {"vtk": run_vtk, "openvdb": run_openvdb}[peer]
    # import outside the timed region
    if peer == "vtk":
        from vtkmodules import vtkCommonCore, vtkCommonDataModel, vtkImagingStencil  # noqa: F401
        from vtkmodules.util import numpy_support  # noqa: F401
    else:
        import pyopenvdb  # noqa: F401
    import numpy  # noqa: F401
    r0 = resource.getrusage(resource.RUSAGE_SELF)
    secs, ntri, dims, filled = fn(path, n)
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    rss_mb = peak_rss_mb()
    print("RESULT %s %d %s %.3f %.0f %d %.3f" % (peer, ntri, "x".join(map(str, dims)), secs, rss_mb, filled, cpu))


def main(argv):
    if len(argv) >= 1 and argv[0] == "--child":
        child(argv[1], argv[2], int(argv[3]))
        return 0
    missing = []
    # find_spec, not import: the parent must stay small, since on Linux a
    # child's ru_maxrss starts from its parent's peak at fork.
    import importlib.util
    for mod, pkg in (("numpy", "python3-numpy"), ("vtk", "python3-vtk9"), ("pyopenvdb", "python3-openvdb")):
        if importlib.util.find_spec(mod) is None:
            missing.append(pkg)
    if missing:
        print("bench_peers: missing Python modules (%s) for %s; install them with: scripts/setup.sh --peers"
              % (", ".join(missing), sys.executable))
        print("(they are Debian packages for /usr/bin/python3; run this script with /usr/bin/python3)")
        return 0
    cases = DEFAULT_CASES
    repeat = 1
    timeout = None
    tsv = None
    args = []
    it = iter(argv)
    for a in it:
        if a == "--repeat":
            repeat = max(1, int(next(it)))
        elif a.startswith("--repeat="):
            repeat = max(1, int(a.split("=", 1)[1]))
        elif a == "--timeout":
            timeout = float(next(it))
        elif a == "--tsv":
            tsv = next(it)
        elif a != "--quick":
            args.append(a)
    if "--quick" in argv:
        cases = QUICK_CASES
    if args:
        cases = []
        for a in args:
            p, _, nn = a.rpartition(":")
            cases.append((p, int(nn)))
    os.chdir(ROOT)
    def loadavg():
        try:
            with open("/proc/loadavg") as f:
                return " ".join(f.read().split()[:3])
        except OSError:
            return "?"
    load_before = loadavg()
    print("| peer | mesh | triangles | N | grid | seconds | CPU seconds | peak RSS MB | inside voxels |")
    print("|---|---|---:|---:|---|---:|---:|---:|---:|")
    sys.stdout.flush()
    def record(*fields):
        if tsv:
            with open(tsv, "a") as f:
                f.write("\t".join(str(x) for x in fields) + "\n")
    timed_out = {}  # (peer, mesh) -> the N that timed out
    for path, n in cases:
        if not os.path.isfile(path):
            print("| - | %s | missing (scripts/fetch_meshes.sh, scripts/bench/bench.sh makes the _s2/_s3 PLYs) | %d ||||||" % (path, n))
            continue
        for peer in PEERS:
            name = os.path.basename(path)
            best = None
            if (peer, path) in timed_out and timed_out[(peer, path)] <= n:
                print("| %s | %s | | %d | | skipped: took over %g s at N = %d | | | |"
                      % (peer, name, n, timeout, timed_out[(peer, path)]))
                record(peer, name, "-", n, "-", "skipped >%g s" % timeout)
                sys.stdout.flush()
                continue
            for _ in range(repeat):
                try:
                    r = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", peer, path, str(n)],
                                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=timeout)
                except subprocess.TimeoutExpired:
                    timed_out[(peer, path)] = n
                    print("| %s | %s | | %d | | skipped: over %g s | | | |" % (peer, name, n, timeout))
                    record(peer, name, "-", n, "-", "skipped >%g s" % timeout)
                    best = None
                    break
                line = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")]
                if r.returncode != 0 or not line:
                    err = (r.stderr.strip().splitlines() or ["exit %d" % r.returncode])[-1]
                    print("| %s | %s | | %d | | failed: %s | | | |" % (peer, name, n, err[:80]))
                    record(peer, name, "-", n, "-", "failed")
                    best = None
                    break
                _, pr, ntri, dims, secs, rss, filled, cpu = line[0].split()
                if best is None or float(secs) < float(best[3]):
                    rss_max = rss if best is None else max(best[4], rss, key=float)
                    best = [pr, ntri, dims, secs, rss_max, filled, cpu]
                else:
                    best[4] = max(best[4], rss, key=float)
            if best:
                pr, ntri, dims, secs, rss, filled, cpu = best
                print("| %s | %s | %s | %d | %s | %s | %s | %s | %s |" % (pr, name, ntri, n, dims, secs, cpu, rss, filled))
                record(pr, name, ntri, n, dims, secs, cpu, rss, filled)
            sys.stdout.flush()
    print("\nLoad average before / after: %s / %s (%d cores)" % (load_before, loadavg(), os.cpu_count() or 0))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
