/* SPDX-License-Identifier: Apache-2.0 */
/* OpenVDB (.vdb) writer, and its reader (at the end): the second C++ shim (the first: mesh_openmesh.cpp),
 * built as its own plugin, libclvox-vdb.so, when Debian's libopenvdb-dev is
 * there (the Makefile's WITH_OPENVDB); the library loads it on the first
 * .vdb (vdb_plugin.c says why and from where). It links no clvox code: the
 * few library functions it calls come in the host table the library hands
 * to its entry point (the macros below route the calls there).
 *
 * The file holds FLOAT grids (GRID_FOG_VOLUME, background 0): "density" =
 * coverage when the run has it, else occupancy 0/1; a run with both also gets
 * an "occupancy" grid. Only non-zero voxels are set (active), so memory is
 * the sparse tree; each grid is pruned every 8 z-slices (the leaf depth), so
 * a solid interior becomes tiles instead of dense leaves. Transform: OpenVDB
 * puts voxel (i,j,k)'s centre at index point (i,j,k), so index -> world is
 * scale(h) then translate(origin + h/2): voxel (i,j,k) is centred at clvox's
 * origin + (i + 0.5) h (docs/formats.md).
 *
 * The file is written through clvox__outfile (unnamed until complete, every
 * byte checked, named on success, non-regular targets refused) by an
 * io::Stream over a std::streambuf that calls clvox__outfile_write. No
 * exception leaves this file: each entry point catches everything and turns
 * it into a clvox_status with a one-line message. */
#define _Static_assert static_assert
extern "C" {
#include "core/internal.h"
}
#undef _Static_assert

#ifndef CLVOX_HAVE_OPENVDB
#error "write_vdb.cpp is the OpenVDB plugin: build it with OpenVDB (the Makefile's WITH_OPENVDB=1)"
#endif

namespace {
const clvox__vdb_host *g_host; /* set by the entry point */
}
#define clvox__fail (g_host->fail)
#define clvox__outfile_create (g_host->outfile_create)
#define clvox__outfile_write (g_host->outfile_write)
#define clvox__outfile_finish (g_host->outfile_finish)
#define clvox__outfile_discard (g_host->outfile_discard)

#include <openvdb/openvdb.h>
#include <openvdb/io/Stream.h>
#include <openvdb/tools/Prune.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>
#include <exception>
#include <mutex>
#include <new>
#include <ostream>
#include <streambuf>
#include <string>

namespace {

/* A streambuf over the unnamed output file: every write checked. */
class OutfileBuf : public std::streambuf {
  public:
    explicit OutfileBuf(clvox__outfile *f) : f_(f) { setp(buf_, buf_ + sizeof buf_); }
    clvox_status status() const { return st_; }

  protected:
    int_type overflow(int_type c) override
    {
        if (flush_buf() != 0) return traits_type::eof();
        if (!traits_type::eq_int_type(c, traits_type::eof())) {
            *pptr() = traits_type::to_char_type(c);
            pbump(1);
        }
        return traits_type::not_eof(c);
    }
    int sync() override { return flush_buf(); }

  private:
    int flush_buf()
    {
        size_t n = size_t(pptr() - pbase());
        if (st_ == CLVOX_OK && n) st_ = clvox__outfile_write(f_, pbase(), n);
        setp(buf_, buf_ + sizeof buf_);
        return st_ == CLVOX_OK ? 0 : -1;
    }
    clvox__outfile *f_;
    clvox_status st_ = CLVOX_OK;
    char buf_[1 << 16];
};

struct VdbWriter {
    clvox_context *ctx = nullptr;
    std::string path, method, parameters;
    clvox_grid grid{};
    uint32_t channels = 0;
    clvox_compression compression = CLVOX_COMPRESSION_DEFAULT;
    openvdb::FloatGrid::Ptr density, occupancy; /* occupancy: only with coverage */
    uint32_t next_occ = 0, next_cov = 0;
    clvox__outfile of{};
    bool of_open = false;
    ~VdbWriter()
    {
        if (of_open) clvox__outfile_discard(&of);
    }
};

std::once_flag g_init;

openvdb::FloatGrid::Ptr new_grid(const clvox_grid &g, const char *name)
{
    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
    grid->setName(name);
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
    m.preScale(openvdb::Vec3d(g.voxel_size[0], g.voxel_size[1], g.voxel_size[2]));
    m.postTranslate(openvdb::Vec3d(g.origin[0] + 0.5 * g.voxel_size[0], g.origin[1] + 0.5 * g.voxel_size[1],
                                   g.origin[2] + 0.5 * g.voxel_size[2]));
    grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
    return grid;
}

void add_occupancy(openvdb::FloatGrid &grid, const clvox_grid &g, const clvox__fmt_slab *s)
{
    const uint32_t X = g.dims[0], Y = g.dims[1], W = clvox__row_words(X);
    auto acc = grid.getAccessor();
    const uint32_t *row = s->occupancy_bits;
    for (uint32_t k = 0; k < s->nz; k++)
        for (uint32_t y = 0; y < Y; y++, row += W)
            for (uint32_t w = 0; w < W; w++) {
                uint32_t bits = row[w];
                while (bits) {
                    uint32_t b = uint32_t(__builtin_ctz(bits));
                    bits &= bits - 1;
                    acc.setValue(openvdb::Coord(int(w * 32 + b), int(y), int(s->z0 + k)), 1.0f);
                }
            }
}

void add_values(openvdb::FloatGrid &grid, const clvox_grid &g, const clvox__fmt_slab *s, const float *v)
{
    const uint32_t X = g.dims[0], Y = g.dims[1];
    auto acc = grid.getAccessor();
    for (uint32_t k = 0; k < s->nz; k++)
        for (uint32_t y = 0; y < Y; y++)
            for (uint32_t x = 0; x < X; x++, v++)
                if (*v != 0.0f) acc.setValue(openvdb::Coord(int(x), int(y), int(s->z0 + k)), *v);
}

/* Next z of a channel: checks the order, prunes when a leaf layer is complete. */
clvox_status advance(VdbWriter *w, uint32_t &next, const clvox__fmt_slab *s, openvdb::FloatGrid &grid,
                     const char *name)
{
    if (s->z0 != next || s->nz > w->grid.dims[2] - s->z0)
        return clvox__fail(w->ctx, CLVOX_ERR_INTERNAL, "'%s': %s slab z0=%u nz=%u out of order (expected z0=%u)",
                           w->path.c_str(), name, s->z0, s->nz, next);
    uint32_t before = next / 8;
    next += s->nz;
    if (next / 8 != before) openvdb::tools::prune(grid.tree());
    return CLVOX_OK;
}

clvox_status vdb_open(clvox_context *ctx, const clvox__fmt_info *info, void **state)
{
    *state = nullptr;
    VdbWriter *w = nullptr;
    try {
        std::call_once(g_init, [] { openvdb::initialize(); });
        w = new VdbWriter;
        w->ctx = ctx;
        w->path = info->path;
        w->grid = *info->grid;
        w->channels = info->channels;
        w->compression = info->compression;
        w->method = info->method ? info->method : "";
        w->parameters = info->parameters ? info->parameters : "";
        for (int a = 0; a < 3; a++)
            if (w->grid.dims[a] > uint32_t(INT32_MAX))
                throw std::length_error("grid too large for OpenVDB coordinates");
        w->density = new_grid(w->grid, "density");
        if ((w->channels & CLVOX_CHANNEL_COVERAGE) && (w->channels & CLVOX_CHANNEL_OCCUPANCY))
            w->occupancy = new_grid(w->grid, "occupancy");
        clvox_status st = clvox__outfile_create(&w->of, ctx, info->path);
        w->of_open = st == CLVOX_OK || w->of.ctx != nullptr;
        if (st != CLVOX_OK) {
            delete w;
            return st;
        }
        *state = w;
        return CLVOX_OK;
    } catch (const std::bad_alloc &) {
        delete w;
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for the OpenVDB grid of '%s'", info->path);
    } catch (const std::exception &e) {
        delete w;
        return clvox__fail(ctx, CLVOX_ERR_IO, "OpenVDB: cannot start '%s': %s", info->path, e.what());
    } catch (...) {
        delete w;
        return clvox__fail(ctx, CLVOX_ERR_INTERNAL, "OpenVDB: cannot start '%s': unknown exception", info->path);
    }
}

clvox_status vdb_write(void *state, const clvox__fmt_slab *s)
{
    VdbWriter *w = static_cast<VdbWriter *>(state);
    try {
        const bool cov = (w->channels & CLVOX_CHANNEL_COVERAGE) != 0;
        clvox_status st = CLVOX_OK;
        if (s->occupancy_bits && (w->channels & CLVOX_CHANNEL_OCCUPANCY)) {
            openvdb::FloatGrid &g = cov ? *w->occupancy : *w->density;
            add_occupancy(g, w->grid, s);
            st = advance(w, w->next_occ, s, g, "occupancy");
        }
        if (st == CLVOX_OK && s->coverage && cov) {
            add_values(*w->density, w->grid, s, s->coverage);
            st = advance(w, w->next_cov, s, *w->density, "coverage");
        }
        return st;
    } catch (const std::bad_alloc &) {
        return clvox__fail(w->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory for the OpenVDB grid of '%s'",
                           w->path.c_str());
    } catch (const std::exception &e) {
        return clvox__fail(w->ctx, CLVOX_ERR_INTERNAL, "OpenVDB: '%s': %s", w->path.c_str(), e.what());
    } catch (...) {
        return clvox__fail(w->ctx, CLVOX_ERR_INTERNAL, "OpenVDB: '%s': unknown exception", w->path.c_str());
    }
}

void vdb_abort(void *state)
{
    try {
        delete static_cast<VdbWriter *>(state);
    } catch (...) {
    }
}

clvox_status vdb_finish(void *state, uint64_t *bytes)
{
    if (bytes) *bytes = 0;
    VdbWriter *w = static_cast<VdbWriter *>(state);
    clvox_status st = CLVOX_OK;
    /* Outside the try: when a write fails, the stream throws (badbit) with
     * "basic_ios::clear: iostream error"; the cause (strerror, e.g. No space
     * left on device) is the streambuf's status and already in the context. */
    OutfileBuf buf(&w->of);
    try {
        const uint32_t Z = w->grid.dims[2];
        if (((w->channels & CLVOX_CHANNEL_OCCUPANCY) && w->next_occ != Z) ||
            ((w->channels & CLVOX_CHANNEL_COVERAGE) && w->next_cov != Z)) {
            st = clvox__fail(w->ctx, CLVOX_ERR_INTERNAL, "'%s': only %u of %u slices were written; no file written",
                             w->path.c_str(), (w->channels & CLVOX_CHANNEL_COVERAGE) ? w->next_cov : w->next_occ, Z);
            vdb_abort(w);
            return st;
        }
        openvdb::GridPtrVec grids;
        for (const openvdb::FloatGrid::Ptr &g : {w->density, w->occupancy}) {
            if (!g) continue;
            openvdb::tools::prune(g->tree());
            g->insertMeta("clvox_version", openvdb::StringMetadata(CLVOX_VERSION_STRING));
            g->insertMeta("clvox_method", openvdb::StringMetadata(w->method));
            g->insertMeta("clvox_parameters", openvdb::StringMetadata(w->parameters));
            g->insertMeta("clvox_origin_corner",
                          openvdb::Vec3DMetadata(openvdb::Vec3d(w->grid.origin[0], w->grid.origin[1], w->grid.origin[2])));
            g->insertMeta("clvox_voxel_size", openvdb::Vec3DMetadata(openvdb::Vec3d(
                                                   w->grid.voxel_size[0], w->grid.voxel_size[1], w->grid.voxel_size[2])));
            g->insertMeta("clvox_dims", openvdb::Vec3IMetadata(openvdb::Vec3i(
                                             int(w->grid.dims[0]), int(w->grid.dims[1]), int(w->grid.dims[2]))));
            grids.push_back(g);
        }
        {
            std::ostream os(&buf);
            os.exceptions(std::ios::badbit);
            openvdb::io::Stream stream(os);
            if (w->compression == CLVOX_COMPRESSION_NONE) stream.setCompression(openvdb::io::COMPRESS_NONE);
            stream.write(grids);
            os.flush();
        }
        st = buf.status();
        if (st == CLVOX_OK) {
            w->of_open = false;
            st = clvox__outfile_finish(&w->of, bytes); /* discards on failure */
        }
    } catch (const std::bad_alloc &) {
        st = clvox__fail(w->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory writing '%s'", w->path.c_str());
    } catch (const std::exception &e) {
        /* a failed write has its message already (the streambuf's status) */
        if (buf.status() != CLVOX_OK) st = buf.status();
        else if (st == CLVOX_OK)
            st = clvox__fail(w->ctx, CLVOX_ERR_IO, "OpenVDB: writing '%s' failed: %s", w->path.c_str(), e.what());
    } catch (...) {
        st = buf.status() != CLVOX_OK ? buf.status()
                                      : clvox__fail(w->ctx, CLVOX_ERR_INTERNAL,
                                                    "OpenVDB: writing '%s' failed: unknown exception", w->path.c_str());
    }
    vdb_abort(w);
    return st;
}

/* ---- reading a .vdb back (read_volume.c, through clvox__vdb_reader_ops) ----
 * The grids clvox writes: "density" (coverage when there is an "occupancy"
 * grid beside it; else occupancy when every value is 0 or 1, coverage
 * otherwise: the file does not say which) and "occupancy". The grid comes
 * from the clvox_dims, clvox_origin_corner and clvox_voxel_size metadata;
 * a .vdb from elsewhere: from the active voxels' bounding box and the
 * transform's voxel size. Voxels are read one accessor lookup each. */

struct VdbReader {
    clvox_context *ctx = nullptr;
    std::string path;
    openvdb::FloatGrid::Ptr occupancy, coverage;
    openvdb::Coord base; /* index of voxel (0,0,0) */
    uint32_t dims[3] = {0, 0, 0};
};

void vdbr_close(void *state) { delete static_cast<VdbReader *>(state); }

int vdbr_has(void *state, const char *channel)
{
    const VdbReader *r = static_cast<const VdbReader *>(state);
    if (std::strcmp(channel, "occupancy") == 0) return r->occupancy != nullptr;
    if (std::strcmp(channel, "coverage") == 0) return r->coverage != nullptr;
    return 0;
}

template <typename T> bool meta(const openvdb::GridBase &g, const char *name, T &out)
{
    typename openvdb::TypedMetadata<T>::ConstPtr m = g.getMetadata<openvdb::TypedMetadata<T>>(name);
    if (!m) return false;
    out = m->value();
    return true;
}

void copy_meta(const openvdb::GridBase &g, const char *name, char *dst, size_t size)
{
    std::string v;
    if (!meta(g, name, v)) return;
    std::snprintf(dst, size, "%s", v.c_str());
    for (char *p = dst; *p; p++)
        if (static_cast<unsigned char>(*p) < 0x20) *p = ' ';
}

clvox_status vdbr_open(clvox_context *ctx, const char *path, clvox_volume_info *info, void **state)
{
    *state = nullptr;
    VdbReader *r = nullptr;
    try {
        std::call_once(g_init, [] { openvdb::initialize(); });
        r = new VdbReader;
        r->ctx = ctx;
        r->path = path;
        openvdb::io::File file(path);
        file.open(false); /* no delayed loading: the file is read now, whole */
        openvdb::GridPtrVecPtr grids = file.getGrids();
        file.close();
        openvdb::FloatGrid::Ptr density;
        for (const openvdb::GridBase::Ptr &g : *grids) {
            openvdb::FloatGrid::Ptr f = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
            if (!f) continue;
            if (f->getName() == "density" && !density) density = f;
            else if (f->getName() == "occupancy" && !r->occupancy) r->occupancy = f;
        }
        if (!density && !r->occupancy) {
            vdbr_close(r);
            return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s' has no float grid \"density\" or \"occupancy\"", path);
        }
        if (density && r->occupancy) {
            r->coverage = density;
        } else if (density) {
            bool binary = true;
            for (auto it = density->cbeginValueOn(); it && binary; ++it) binary = *it == 0.0f || *it == 1.0f;
            (binary ? r->occupancy : r->coverage) = density;
        }
        const openvdb::FloatGrid &g = density ? *density : *r->occupancy;
        openvdb::Vec3i d;
        openvdb::Vec3d o, h;
        if (meta(g, "clvox_dims", d) && meta(g, "clvox_origin_corner", o) && meta(g, "clvox_voxel_size", h)) {
            for (int a = 0; a < 3; a++) {
                if (d[a] < 1 || uint64_t(d[a]) > CLVOX_MAX_AXIS || !(h[a] > 0) || !std::isfinite(o[a])) {
                    vdbr_close(r);
                    return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s': bad clvox_dims or clvox_voxel_size", path);
                }
                r->dims[a] = uint32_t(d[a]);
                info->origin[a] = o[a];
                info->voxel_size[a] = h[a];
            }
            r->base = openvdb::Coord(0, 0, 0);
        } else {
            openvdb::CoordBBox bb = g.evalActiveVoxelBoundingBox();
            const openvdb::Vec3d vs = g.voxelSize();
            if (bb.empty() || !g.transform().isLinear()) {
                vdbr_close(r);
                return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s': an empty or non-linear grid, without clvox metadata",
                                   path);
            }
            r->base = bb.min();
            const openvdb::Vec3d c = g.indexToWorld(bb.min());
            for (int a = 0; a < 3; a++) {
                const int64_t n = int64_t(bb.max()[a]) - bb.min()[a] + 1;
                if (n > int64_t(CLVOX_MAX_AXIS)) {
                    vdbr_close(r);
                    return clvox__fail(ctx, CLVOX_ERR_EXR, "'%s': the grid is too large (%lld voxels along %c)", path,
                                       (long long)n, "xyz"[a]);
                }
                r->dims[a] = uint32_t(n);
                info->voxel_size[a] = vs[a];
                info->origin[a] = c[a] - 0.5 * vs[a];
            }
        }
        for (int a = 0; a < 3; a++) info->dims[a] = r->dims[a];
        copy_meta(g, "clvox_method", info->method, sizeof info->method);
        copy_meta(g, "clvox_parameters", info->parameters, sizeof info->parameters);
        copy_meta(g, "clvox_version", info->version, sizeof info->version);
        *state = r;
        return CLVOX_OK;
    } catch (const std::bad_alloc &) {
        vdbr_close(r);
        return clvox__fail(ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", path);
    } catch (const std::exception &e) {
        vdbr_close(r);
        return clvox__fail(ctx, CLVOX_ERR_EXR, "OpenVDB: cannot read '%s': %s", path, e.what());
    } catch (...) {
        vdbr_close(r);
        return clvox__fail(ctx, CLVOX_ERR_EXR, "OpenVDB: cannot read '%s'", path);
    }
}

clvox_status vdbr_read(void *state, const char *channel, clvox__vdb_band_fn fn, void *user)
{
    VdbReader *r = static_cast<VdbReader *>(state);
    openvdb::FloatGrid::Ptr g = std::strcmp(channel, "occupancy") == 0 ? r->occupancy
                                : std::strcmp(channel, "coverage") == 0 ? r->coverage : nullptr;
    if (!g) return clvox__fail(r->ctx, CLVOX_ERR_EXR, "'%s' has no channel \"%s\"", r->path.c_str(), channel);
    const uint32_t X = r->dims[0], Y = r->dims[1], Z = r->dims[2];
    try {
        std::vector<float> slice(size_t(X) * Y);
        auto acc = g->getConstAccessor();
        for (uint32_t z = 0; z < Z; z++) {
            for (uint32_t y = 0; y < Y; y++)
                for (uint32_t x = 0; x < X; x++)
                    slice[size_t(y) * X + x] = acc.getValue(r->base.offsetBy(int(x), int(y), int(z)));
            clvox_status st = fn(user, reinterpret_cast<const uint8_t *>(slice.data()), 2 /* FLOAT */,
                                 uint64_t(z) * Y, Y);
            if (st != CLVOX_OK) return st;
        }
        return CLVOX_OK;
    } catch (const std::bad_alloc &) {
        return clvox__fail(r->ctx, CLVOX_ERR_OUT_OF_MEMORY, "out of memory reading '%s'", r->path.c_str());
    } catch (...) {
        return clvox__fail(r->ctx, CLVOX_ERR_INTERNAL, "OpenVDB: reading '%s' failed", r->path.c_str());
    }
}

} // namespace

/* The reader's entry point: its ops, or NULL for another library. */
extern "C" __attribute__((visibility("default"))) const clvox__vdb_reader_ops *
clvox__vdb_plugin_reader(const clvox__vdb_host *host, uint32_t abi, const char *version)
{
    static const clvox__vdb_reader_ops ops = {vdbr_open, vdbr_has, vdbr_read, vdbr_close};
    if (!host || abi != CLVOX__VDB_READER_ABI || !version || std::strcmp(version, CLVOX_VERSION_STRING) != 0)
        return nullptr;
    g_host = host;
    return &ops;
}

/* The plugin's entry point (the library looks it up by name): its ops, or NULL for
 * a library of another version or layout. */
extern "C" __attribute__((visibility("default"))) const clvox__fmt_ops *
clvox__vdb_plugin(const clvox__vdb_host *host, uint32_t abi, const char *version)
{
    static const clvox__fmt_ops ops = {
        "vdb", CLVOX_CHANNEL_OCCUPANCY | CLVOX_CHANNEL_COVERAGE, 1, 0, vdb_open, vdb_write, vdb_finish, vdb_abort};
    if (!host || abi != CLVOX__VDB_ABI || !version || std::strcmp(version, CLVOX_VERSION_STRING) != 0) return nullptr;
    g_host = host;
    return &ops;
}
