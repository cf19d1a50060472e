/* SPDX-License-Identifier: Apache-2.0 */
/* OpenMesh's OM format: checked here, read by OpenMesh (mesh_openmesh.cpp). */
#include "mesh_internal.h"
#include "mesh_scan.h"

/* OpenMesh's OM reader asserts (abort()) on chunk headers with unexpected
 * dimensions and, without an end marker, accepts a truncated file. So the
 * chunk sequence is walked here exactly as OMReader.cc consumes it (OM files
 * are little endian): every chunk must fit the file, asserted dimensions must
 * hold, and the sentinel chunk must be reached. Halfedge ids are checked when
 * faces are rebuilt (mesh_openmesh.cpp), vertex ids by clvox__mesh_build. */
clvox_status clvox__mesh_check_om(clvox_context *ctx, const char *path, const unsigned char *p, size_t n)
{
    if (n < 16 || p[0] != 'O' || p[1] != 'M' || (p[2] != 'T' && p[2] != 'Q' && p[2] != 'P'))
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s' is not an OpenMesh OM file (bad magic)", path);
    unsigned version = p[3], mesh_type = p[2];
    uint64_t nv = le32(p + 4), nf = le32(p + 8), ne = le32(p + 12);
    if (version > 0x42) /* OM 2.2, what OpenMesh 9.0 writes and reads */
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM format version %u.%u is not supported", path,
                           version >> 5, version & 31);
    /* Positions take at least 12 bytes a vertex. */
    if (nv > n / 12)
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT,
                           "'%s': OM header declares %llu vertices, more than its %zu bytes hold", path,
                           (unsigned long long)nv, n);
    size_t pos = 16;
    for (unsigned chunk = 0;; chunk++) {
        if (n - pos < 2)
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM file is truncated (no end marker after chunk %u)",
                               path, chunk);
        unsigned h = (unsigned)p[pos] | (unsigned)p[pos + 1] << 8;
        pos += 2;
        unsigned named = h >> 1 & 1, entity = h >> 2 & 7, type = h >> 5 & 15, is_float = h >> 10 & 1;
        unsigned dims = (h >> 11 & 7) + 1, bits = h >> 14 & 3, isz = 1u << bits;
        if (entity == 7) return CLVOX_OK; /* sentinel */
        if (named) {
            if (n - pos < 1 || n - pos - 1 < p[pos]) goto truncated;
            pos += 1 + (size_t)p[pos];
        }
        uint64_t count;
        switch (entity) {
        case 0: count = nv; break;
        case 1: count = 1; break;
        case 2: count = nf; break;
        case 4: count = ne; break;
        case 6: count = 2 * ne; break;
        default:
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM chunk %u has an unknown entity %u", path, chunk,
                               entity);
        }
        uint64_t scalar = is_float ? (1u << bits) : (4u << bits);
        uint64_t size = count * dims * scalar; /* the reader's skip size for other chunks */
        int need_dims = 0, must_consume = entity == 1 || entity == 4 || entity == 6;
        if (type == 6) { /* custom property: [type name,] uint32 block size, block */
            if (version > 0x41) {
                if (n - pos < 1 || n - pos - 1 < p[pos]) goto truncated;
                pos += 1 + (size_t)p[pos];
            }
            if (n - pos < 4) goto truncated;
            size = le32(p + pos);
            pos += 4;
            must_consume = 0;
        } else if (entity == 0 || (entity == 2 && (type == 1 || type == 3 || type == 4 || type == 7))) {
            switch (type) {
            case 0: /* positions (vertices only) */
            case 1: /* normals */
                if (type == 0 && entity == 2) break;
                need_dims = 3;
                if (bits == 0) size = 12 * count;
                else if (bits == 1) size = 24 * count;
                else if (count)
                    return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM chunk %u has an unsupported scalar size",
                                       path, chunk);
                else size = 0;
                break;
            case 2: need_dims = 2, size = 8 * count; break;
            case 3: need_dims = 1, size = 4 * count; break;
            case 4: need_dims = 3, size = 3 * count; break;
            case 7: /* topology */
                if (entity == 2 && version < 0x40) { /* faces as vertex index lists */
                    uint64_t corners = mesh_type == 'T' ? 3 : 4;
                    for (uint64_t f = 0; f < nf; f++) {
                        if (mesh_type == 'P') {
                            if (n - pos < 2) goto truncated;
                            corners = (uint64_t)p[pos] | (uint64_t)p[pos + 1] << 8;
                            pos += 2;
                        }
                        if ((n - pos) / isz < corners) goto truncated;
                        pos += corners * isz;
                    }
                    size = 0;
                } else {
                    size = count * isz;
                }
                break;
            default: break;
            }
        } else if (entity == 6 && type == 2) {
            need_dims = 2, size = 8 * count;
        } else if (entity == 6 && type == 7) {
            size = ne * 6 * isz;
        } else if ((entity == 4 || entity == 6) && type == 3) {
            need_dims = 1, size = 4 * count;
        }
        if (need_dims && dims != (unsigned)need_dims)
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM chunk %u is corrupt (%u-D data where %d-D is required)",
                               path, chunk, dims, need_dims);
        if (must_consume && size == 0)
            return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM chunk %u is empty", path, chunk);
        if (size > n - pos) goto truncated;
        pos += size;
        continue;
    truncated:
        return clvox__fail(ctx, CLVOX_ERR_MESH_FORMAT, "'%s': OM file is truncated in chunk %u", path, chunk);
    }
}
