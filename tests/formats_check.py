# SPDX-License-Identifier: Apache-2.0
"""Independent read-back of clvox's npy, NRRD, binvox and OpenVDB files (tests/test_formats.c).
   formats_check.py FORMAT FILE REF DTYPE X Y Z OX OY OZ H [bits | grid=NAME]
vdb: pyopenvdb (Debian python3-openvdb); grid=NAME reads that grid (default density).
REF: the reference voxels as raw little-endian DTYPE (u8 or f32), x fastest,
from clvox_voxelize_to_buffers. Prints OK or what differs; exit 0 on OK."""
import json, sys
import numpy as np

fmt, path, ref_path, dt = sys.argv[1:5]
X, Y, Z = (int(v) for v in sys.argv[5:8])
origin = np.array([float(v) for v in sys.argv[8:11]])
h = float(sys.argv[11])
bits = len(sys.argv) > 12 and sys.argv[12] == "bits"
grid_name = sys.argv[12][5:] if len(sys.argv) > 12 and sys.argv[12].startswith("grid=") else "density"
ref = np.fromfile(ref_path, dtype="<u1" if dt == "u8" else "<f4").reshape(Z, Y, X)

def fail(msg):
    print("MISMATCH", msg)
    sys.exit(1)

if fmt == "npy":
    a = np.load(path, mmap_mode="r")
    if bits:
        if a.shape != (Z, Y, (X + 7) // 8) or a.dtype != np.uint8: fail("packed shape %s" % (a.shape,))
        a = np.unpackbits(a, axis=2, bitorder="little")[:, :, :X]
    if a.shape != (Z, Y, X): fail("shape %s" % (a.shape,))
    if dt == "u8":
        if not np.array_equal(np.asarray(a), ref): fail("%d voxels differ" % int((np.asarray(a) != ref).sum()))
    else:
        d = np.abs(np.asarray(a, dtype=np.float64) - ref)
        tol = 0.0 if a.dtype == np.float32 else 2.0 ** -11
        if d.max() > tol: fail("coverage differs by %g (%s)" % (d.max(), a.dtype))
    side = json.load(open(path[:-4] + ".json" if not ".coverage" in path else path.split(".coverage")[0] + ".json"))
    if side["shape"] != [Z, Y, X] or not np.allclose(side["origin"], origin, rtol=0, atol=1e-12) \
            or not np.allclose(side["voxel_size"], [h] * 3, rtol=1e-15): fail("sidecar %s" % side)
elif fmt == "nrrd":
    import nrrd
    a, hdr = nrrd.read(path, index_order="C")
    if a.shape != (Z, Y, X): fail("shape %s" % (a.shape,))
    if dt == "u8":
        if not np.array_equal(a, ref): fail("%d voxels differ" % int((a != ref).sum()))
    elif np.abs(a - ref).max() > 0: fail("coverage differs")
    # world position of voxel (i, j, k) = space origin + directions @ (i, j, k): clvox's centre
    so = np.asarray(hdr["space origin"], dtype=np.float64)
    sd = np.asarray(hdr["space directions"], dtype=np.float64)
    ijk = np.array([3.0, 5.0, 7.0])
    want = origin + (ijk + 0.5) * h
    got = so + sd.T @ ijk
    if not np.allclose(got, want, rtol=0, atol=1e-12): fail("voxel centre %s vs %s" % (got, want))
    if hdr.get("space") != "left-posterior-superior": fail("space %s" % hdr.get("space"))
elif fmt == "binvox":
    from trimesh.exchange import binvox
    with open(path, "rb") as f:
        vg = binvox.load_binvox(f)
    m = np.asarray(vg.matrix)  # (x, y, z)
    if m.shape != (X, Y, Z): fail("shape %s" % (m.shape,))
    if not np.array_equal(m, ref.transpose(2, 1, 0).astype(bool)):
        fail("%d voxels differ" % int((m != ref.transpose(2, 1, 0).astype(bool)).sum()))
    with open(path, "rb") as f:
        p = binvox.parse_binvox(f)
    if not np.allclose(p.translate, origin, rtol=0, atol=1e-12) or abs(p.scale - X * h) > 1e-12:
        fail("translate %s scale %s" % (p.translate, p.scale))
elif fmt == "vdb":
    import pyopenvdb as vdb
    grids, _ = vdb.readAll(path)
    byname = {g.name: g for g in grids}
    if grid_name not in byname: fail("no grid %r (%s)" % (grid_name, list(byname)))
    g = byname[grid_name]
    if g.valueTypeName != "float" or g.gridClass != vdb.GridClass.FOG_VOLUME or g.background != 0.0:
        fail("grid type %s class %s background %s" % (g.valueTypeName, g.gridClass, g.background))
    a = np.zeros((X, Y, Z), dtype=np.float32)  # a[i, j, k] = voxel (i, j, k)
    g.copyToArray(a, ijk=(0, 0, 0))
    want = ref.transpose(2, 1, 0).astype(np.float32)
    half = len(sys.argv) > 12 and sys.argv[12] == "half"
    if half:
        if np.abs(a - want).max() > 2.0 ** -11 or not np.array_equal(a != 0, want != 0):
            fail("values differ by %g" % np.abs(a - want).max())
    elif not np.array_equal(a, want): fail("%d voxels differ" % int((a != want).sum()))
    # sparse: exactly the non-zero voxels are active, none outside the grid
    if g.activeVoxelCount() != int(np.count_nonzero(want)):
        fail("%d active voxels, %d non-zero" % (g.activeVoxelCount(), np.count_nonzero(want)))
    lo, hi = g.evalActiveVoxelBoundingBox()
    if g.activeVoxelCount() and (min(lo) < 0 or hi[0] >= X or hi[1] >= Y or hi[2] >= Z): fail("bbox %s %s" % (lo, hi))
    # world position of voxel (i, j, k)'s centre (OpenVDB: index point (i, j, k)) = clvox's centre
    ijk = (3, 5, 7)
    got = np.array(g.transform.indexToWorld(ijk))
    wantw = origin + (np.array(ijk) + 0.5) * h
    if not np.allclose(got, wantw, rtol=0, atol=1e-9): fail("voxel centre %s vs %s" % (got, wantw))
    if not np.allclose(g.transform.voxelSize(), [h] * 3, rtol=1e-12): fail("voxel size %s" % (g.transform.voxelSize(),))
    if not np.allclose(g.metadata["clvox_origin_corner"], origin, rtol=0, atol=1e-12): fail("metadata %s" % g.metadata)
else:
    fail("unknown format " + fmt)
print("OK")
