/* SPDX-License-Identifier: Apache-2.0 */
/* The only C++ file: a shim around OpenMesh's readers that hands back the
 * polygons exactly as the file lists them.
 *
 * Every format goes through OpenMesh's IOManager (the reader picked by
 * extension, as in read_mesh) into RawImporter below, which records vertices
 * and faces without building a halfedge mesh. So nothing is dropped or
 * re-added behind our back: out-of-range and repeated indices reach
 * mesh_build.c, which reports them. (ImporterT, what read_mesh uses, silently drops faces
 * with an invalid or repeated index, re-adds non-manifold faces with
 * duplicated vertices - a closed mesh with one flipped triangle would come
 * back open - and asserts, i.e. aborts, on out-of-range halfedge ids in an
 * OM file.)
 *
 * OM files store halfedge topology: the importer records it (to-vertex and
 * next of each halfedge, one halfedge per face) and faces are rebuilt by
 * walking the next links with bounds checks. The OM reader insists on a
 * property kernel; it gets an empty BaseKernel, so custom properties are
 * skipped.
 *
 * mesh_load.c has every file checked (mesh_<format>.c) before it gets here:
 * OpenMesh hangs, throws, aborts or reads garbage on bad input (NOTES-deps).
 * This file still catches everything, silences OpenMesh's console output
 * and serialises calls (the readers are singletons with per-file state). */
#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/Mesh/BaseKernel.hh>
#include <OpenMesh/Core/System/omstream.hh>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <iostream>
#include <mutex>
#include <new>
#include <stdexcept>
#include <streambuf>
#include <string>

/* internal.h is a C header: no extern "C" block of its own, and the shared
 * kernel types pin their layout with C11's _Static_assert. */
#define _Static_assert static_assert
extern "C" {
#include "core/internal.h"
}
#undef _Static_assert

namespace {

using OpenMesh::EdgeHandle;
using OpenMesh::FaceHandle;
using OpenMesh::HalfedgeHandle;
using OpenMesh::VertexHandle;
using OpenMesh::Vec2f;
using OpenMesh::Vec3d;
using OpenMesh::Vec3f;
using OpenMesh::Vec3uc;
using OpenMesh::Vec4f;
using OpenMesh::Vec4uc;
using StatusInfo = OpenMesh::Attributes::StatusInfo;

/* A malloc'ed growable array, so the result can be handed to C as is. */
template <typename T> struct Buf {
    T *data = nullptr;
    size_t size = 0, cap = 0;
    ~Buf() { std::free(data); }
    void reserve(size_t n)
    {
        if (n <= cap) return;
        if (n > SIZE_MAX / sizeof(T)) throw std::bad_alloc();
        T *p = static_cast<T *>(std::realloc(data, n * sizeof(T)));
        if (!p) throw std::bad_alloc();
        data = p;
        cap = n;
    }
    void push(T v)
    {
        if (size == cap) reserve(cap < 1024 ? 1024 : cap + cap / 2);
        data[size++] = v;
    }
    T *release()
    {
        T *p = data;
        data = nullptr;
        size = cap = 0;
        return p;
    }
};

/* Reserve hints come from file headers; the format checks (mesh_<format>.c)
 * have checked them against the file size, but never trust a hint beyond
 * this. */
const size_t kMaxReserve = size_t(1) << 26;

class RawImporter : public OpenMesh::IO::BaseImporter {
public:
    Buf<float> xyz;
    Buf<uint32_t> sizes, indices;
    /* OM halfedge topology: halfedge 2e and 2e+1 are the two sides of edge e. */
    Buf<int32_t> he_to, he_next, face_he;
    OpenMesh::BaseKernel no_properties;

    VertexHandle add_vertex(const Vec3f &p) override
    {
        xyz.push(p[0]);
        xyz.push(p[1]);
        xyz.push(p[2]);
        return VertexHandle(int(xyz.size / 3 - 1));
    }
    VertexHandle add_vertex(const Vec3d &p) override
    {
        return add_vertex(Vec3f(float(p[0]), float(p[1]), float(p[2])));
    }
    VertexHandle add_vertex() override { return add_vertex(Vec3f(0.0f, 0.0f, 0.0f)); }
    void set_point(VertexHandle vh, const Vec3f &p) override
    {
        if (vh.idx() < 0 || size_t(vh.idx()) >= xyz.size / 3) return;
        float *d = xyz.data + 3 * size_t(vh.idx());
        d[0] = p[0];
        d[1] = p[1];
        d[2] = p[2];
    }
    FaceHandle add_face(const VHandles &v) override
    {
        sizes.push(uint32_t(v.size()));
        /* Kept verbatim: an invalid handle (-1) becomes 0xFFFFFFFF, out of range. */
        for (const VertexHandle &h : v) indices.push(uint32_t(h.idx()));
        return FaceHandle(int(sizes.size - 1));
    }
    void reserve(unsigned int nV, unsigned int, unsigned int nF) override
    {
        xyz.reserve(3 * std::min<size_t>(nV, kMaxReserve));
        sizes.reserve(std::min<size_t>(nF, kMaxReserve));
        indices.reserve(3 * std::min<size_t>(nF, kMaxReserve));
    }
    size_t n_vertices() const override { return xyz.size / 3; }
    size_t n_faces() const override { return sizes.size; }
    size_t n_edges() const override { return 0; }

    /* OM topology (as ArrayKernel::new_edge: the first halfedge points to vh1). */
    HalfedgeHandle add_edge(VertexHandle vh0, VertexHandle vh1) override
    {
        he_to.push(vh1.idx());
        he_to.push(vh0.idx());
        he_next.push(-1);
        he_next.push(-1);
        return HalfedgeHandle(int(he_to.size - 2));
    }
    void set_next(HalfedgeHandle heh, HalfedgeHandle next) override
    {
        if (heh.idx() >= 0 && size_t(heh.idx()) < he_next.size) he_next.data[heh.idx()] = next.idx();
    }
    FaceHandle add_face(HalfedgeHandle heh) override
    {
        face_he.push(heh.idx());
        return FaceHandle(int(face_he.size - 1));
    }
    OpenMesh::BaseKernel *kernel() override { return &no_properties; }

    /* Appends the OM faces: walks each face's next links. Returns false on
     * broken topology (an id out of range, a loop that does not close). */
    bool rebuild_om_faces()
    {
        size_t nh = he_to.size;
        for (size_t f = 0; f < face_he.size; f++) {
            int32_t h0 = face_he.data[f], h = h0;
            uint32_t n = 0;
            do {
                if (h < 0 || size_t(h) >= nh || n >= nh) return false;
                indices.push(uint32_t(he_to.data[h]));
                n++;
                h = he_next.data[h];
            } while (h != h0);
            sizes.push(n);
        }
        return true;
    }

    /* Attributes: not needed. */
    void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<Vec2f> &) override {}
    void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<Vec3f> &) override {}
    void set_face_texindex(FaceHandle, int) override {}
    void set_halfedge(VertexHandle, HalfedgeHandle) override {}
    void set_normal(VertexHandle, const Vec3f &) override {}
    void set_normal(VertexHandle, const Vec3d &) override {}
    void set_color(VertexHandle, const Vec3uc &) override {}
    void set_color(VertexHandle, const Vec4uc &) override {}
    void set_color(VertexHandle, const Vec3f &) override {}
    void set_color(VertexHandle, const Vec4f &) override {}
    void set_texcoord(VertexHandle, const Vec2f &) override {}
    void set_status(VertexHandle, const StatusInfo &) override {}
    void set_face(HalfedgeHandle, FaceHandle) override {}
    void request_face_texcoords2D() override {}
    void set_texcoord(HalfedgeHandle, const Vec2f &) override {}
    void set_texcoord(VertexHandle, const Vec3f &) override {}
    void set_texcoord(HalfedgeHandle, const Vec3f &) override {}
    void set_status(HalfedgeHandle, const StatusInfo &) override {}
    void set_color(EdgeHandle, const Vec3uc &) override {}
    void set_color(EdgeHandle, const Vec4uc &) override {}
    void set_color(EdgeHandle, const Vec3f &) override {}
    void set_color(EdgeHandle, const Vec4f &) override {}
    void set_status(EdgeHandle, const StatusInfo &) override {}
    void set_normal(FaceHandle, const Vec3f &) override {}
    void set_normal(FaceHandle, const Vec3d &) override {}
    void set_color(FaceHandle, const Vec3uc &) override {}
    void set_color(FaceHandle, const Vec4uc &) override {}
    void set_color(FaceHandle, const Vec3f &) override {}
    void set_color(FaceHandle, const Vec4f &) override {}
    void set_status(FaceHandle, const StatusInfo &) override {}
    void add_texture_information(int, std::string) override {}
};

/* Swallows everything written to it. */
class NullBuf : public std::streambuf {
protected:
    int overflow(int c) override { return traits_type::not_eof(c); }
    std::streamsize xsputn(const char *, std::streamsize n) override { return n; }
};

/* Silences OpenMesh's streams and std::cerr/std::clog (some readers write to
 * std::cerr directly) for the duration of a read, and restores them even
 * when the reader throws. Only constructed under g_read_lock. */
class Quiet {
public:
    Quiet()
        : err_(omerr().is_enabled()), log_(omlog().is_enabled()), out_(omout().is_enabled()),
          cerr_(std::cerr.rdbuf(&null_)), clog_(std::clog.rdbuf(&null_))
    {
        omerr().disable();
        omlog().disable();
        omout().disable();
    }
    ~Quiet()
    {
        std::cerr.rdbuf(cerr_);
        std::clog.rdbuf(clog_);
        if (err_) omerr().enable();
        if (log_) omlog().enable();
        if (out_) omout().enable();
    }
    Quiet(const Quiet &) = delete;
    Quiet &operator=(const Quiet &) = delete;

private:
    NullBuf null_;
    bool err_, log_, out_;
    std::streambuf *cerr_, *clog_;
};

std::mutex g_read_lock;

void set_err(char *err, size_t size, const char *msg)
{
    if (err && size) std::snprintf(err, size, "%s", msg);
}

bool read_raw(const char *path, clvox__raw_mesh *out)
{
    RawImporter imp;
    OpenMesh::IO::Options opt; /* nothing optional: no normals, colours, custom properties */
    if (!OpenMesh::IO::IOManager().read(std::string(path), imp, opt)) return false;
    if (imp.face_he.size && !imp.rebuild_om_faces()) throw std::runtime_error("corrupt OM halfedge topology");
    out->vertex_count = imp.xyz.size / 3;
    out->face_count = imp.sizes.size;
    out->index_count = imp.indices.size;
    out->nonmanifold_faces = 0;
    out->xyz = imp.xyz.release();
    out->face_sizes = imp.sizes.release();
    out->face_indices = imp.indices.release();
    return true;
}

} // namespace

/* Returns 0 on success, -2 when memory ran out, -1 for any other failure. */
extern "C" int clvox__openmesh_read(const char *path, clvox__raw_mesh *out, char *err, size_t err_size)
{
    if (!path || !out) {
        set_err(err, err_size, "NULL argument");
        return -1;
    }
    std::memset(out, 0, sizeof *out);
    try {
        std::lock_guard<std::mutex> lock(g_read_lock);
        Quiet quiet;
        if (!read_raw(path, out)) {
            clvox__raw_mesh_free(out);
            set_err(err, err_size, "OpenMesh could not parse the file (truncated or corrupt?)");
            return -1;
        }
        /* Vertex handles are ints: beyond that OpenMesh's indices wrap. */
        if (out->vertex_count > size_t(INT32_MAX)) {
            clvox__raw_mesh_free(out);
            set_err(err, err_size, "more than 2^31 vertices");
            return -1;
        }
        return 0;
    } catch (const std::bad_alloc &) {
        clvox__raw_mesh_free(out);
        set_err(err, err_size, "out of memory while reading");
        return -2;
    } catch (const std::exception &e) {
        clvox__raw_mesh_free(out);
        if (err && err_size) std::snprintf(err, err_size, "OpenMesh failed: %s", e.what());
        return -1;
    } catch (...) {
        clvox__raw_mesh_free(out);
        set_err(err, err_size, "OpenMesh failed with an unknown exception");
        return -1;
    }
}
