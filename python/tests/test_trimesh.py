# SPDX-License-Identifier: Apache-2.0
"""trimesh objects as input (trimesh: build/venv-formats, scripts/setup.sh; skipped without it)."""
import tracemalloc

import numpy as np
import pytest

from clvox._core import _as_arrays

trimesh = pytest.importorskip("trimesh")


def _meshes():
    ico = trimesh.creation.icosphere(subdivisions=3, radius=0.8)
    box = trimesh.creation.box(extents=(1.0, 0.6, 0.35))
    box.apply_transform(trimesh.transformations.rotation_matrix(0.4, [1, 2, 3]))
    return [("icosphere", ico), ("box", box)]


@pytest.mark.parametrize("name,tm", _meshes(), ids=lambda x: x if isinstance(x, str) else "")
def test_trimesh_equals_its_arrays(ctx, name, tm):
    assert isinstance(tm, trimesh.Trimesh) and tm.is_watertight
    V, F = np.array(tm.vertices), np.array(tm.faces)   # plain float64 / int64 copies
    assert V.dtype == np.float64 and F.dtype == np.int64
    ref = ctx.voxelize((V, F), resolution=40, oversample=2, channels="occupancy,coverage")
    vol = ctx.voxelize(tm, resolution=40, oversample=2, channels="occupancy,coverage")
    assert vol.dims == ref.dims and vol.origin == ref.origin and vol.voxel_size == ref.voxel_size
    assert np.array_equal(vol.occupancy, ref.occupancy) and ref.occupancy.sum() > 100
    assert np.array_equal(vol.coverage, ref.coverage)
    assert vol.report["triangles"] == len(tm.faces) and vol.report["closed"]
    # solid voxel count near the mesh's volume (a wrong vertex order or cast would not be)
    assert abs(vol.coverage.sum() * np.prod(vol.voxel_size) - tm.volume) < 0.05 * tm.volume
    # a clvox.Mesh made from it and the file writer take it too
    m = ctx.mesh(tm)
    assert np.array_equal(ctx.voxelize(m, resolution=40, oversample=2, channels="occupancy,coverage").coverage,
                          ref.coverage)


def test_trimesh_one_copy_at_most():
    tm = trimesh.creation.icosphere(subdivisions=6)   # 40962 vertices, 81920 faces
    nv, nf = len(tm.vertices), len(tm.faces)
    converted = nv * 3 * 4 + nf * 3 * 4                # float32 + uint32: the one copy
    tm.vertices, tm.faces                              # trimesh's own lazy state, outside the measure
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        v, f = _as_arrays(tm.vertices, tm.faces)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    assert v.dtype == np.float32 and f.dtype == np.uint32 and v.flags.c_contiguous and f.flags.c_contiguous
    assert np.array_equal(v, np.asarray(tm.vertices, dtype=np.float32))
    assert np.array_equal(f, tm.faces)
    # the float64 / int64 arrays would be 2x that: no intermediate copy of either
    assert converted <= peak < converted + nv * 3 * 4 // 2, (peak, converted)
    # and a float32 / uint32 view of the same data is passed with no copy at all
    v32, f32 = v, f
    v2, f2 = _as_arrays(v32, f32)
    assert np.shares_memory(v2, v32) and np.shares_memory(f2, f32)
