# SPDX-License-Identifier: Apache-2.0
"""clvox: OpenCL voxelization of triangle meshes, numpy in and out.

    import clvox
    ctx = clvox.Context()                     # one OpenCL device, kernels built once
    vol = ctx.voxelize("bunny.off", resolution=128)
    vol.occupancy                             # bool array, shape (Z, Y, X)

Arrays are (Z, Y, X) in C order: vol.occupancy[k, j, i] is voxel (i, j, k), whose centre is
origin + (i + 0.5, j + 0.5, k + 0.5) * voxel_size (x fastest, as the library and the file).
"""
from ._core import (STATUS, CancelledError, Context, Error, InvalidError, Mesh, Slab, Volume,  # noqa: F401
                    batch, devices, palettes, read, read_info, version)
from ._pocl import use_pocl_binary_distribution  # noqa: F401

__version__ = "0.1.0"
