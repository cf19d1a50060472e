/* SPDX-License-Identifier: Apache-2.0 */
/* A shim around Assimp (Debian's libassimp 5.2) for the formats clvox has
 * no reader of its own for: glTF 2.0 (.gltf with its buffers, .glb), 3MF,
 * FBX, DAE, 3DS and the rest Assimp reads.
 *
 * Assimp reads through an IOSystem of ours (MemIO below): the file itself is
 * the buffer mesh_load.c already read and checked (so it cannot change
 * between the check and the parse), other files it names (a .gltf's .bin)
 * are opened only when they are regular files (a FIFO would block) and read
 * whole, and the reason one was refused is added to Assimp's message;
 * nothing is ever written. Import flags: triangulate, split meshes by
 * primitive type (lines and points are then counted and left out) and
 * validate the data structure.
 *
 * The scene is flattened here, not by aiProcess_PreTransformVertices: every
 * node's transform (composed in double from the root) applied to every mesh
 * it references, so an instanced mesh appears once per placement; vertices
 * stored relative to the first flattened vertex (as the OBJ reader does),
 * so a scene far from the origin keeps its precision; vertices at exactly
 * the same position within a mesh merged. The flattened size is
 * bounded: at most 64 MiB + 256 x the unique meshes' own size (a small
 * file that places one big mesh a million times is refused, not expanded),
 * and the node walk stops at a node count or depth a tree cannot exceed.
 *
 * Assimp's parsers have a long CVE history; everything is caught here, but
 * a crash or an abort (Debian builds Assimp with its assertions) cannot be:
 * mesh_isolate.c runs this in a child process. tests/fuzz/fuzz_mesh_assimp.c
 * fuzzes it in-process. */
#include <assimp/IOStream.hpp>
#include <assimp/IOSystem.hpp>
#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <tuple>
#include <algorithm>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

#define _Static_assert static_assert
extern "C" {
#include "core/internal.h"
}
#undef _Static_assert

namespace {

/* A read-only stream over bytes it may own. */
class MemStream : public Assimp::IOStream {
public:
    MemStream(const unsigned char *p, size_t n, std::vector<unsigned char> &&own)
        : own_(std::move(own)), p_(own_.empty() ? p : own_.data()), n_(n)
    {
    }
    size_t Read(void *buf, size_t size, size_t count) override
    {
        if (!size || !count || pos_ >= n_) return 0;
        size_t items = (n_ - pos_) / size;
        if (items > count) items = count;
        std::memcpy(buf, p_ + pos_, items * size);
        pos_ += items * size;
        return items;
    }
    size_t Write(const void *, size_t, size_t) override { return 0; }
    aiReturn Seek(size_t off, aiOrigin origin) override
    {
        size_t base = origin == aiOrigin_SET ? 0 : origin == aiOrigin_CUR ? pos_ : n_;
        if (origin != aiOrigin_SET && origin != aiOrigin_CUR && origin != aiOrigin_END) return aiReturn_FAILURE;
        if (off > n_ || base > n_ - off) return aiReturn_FAILURE;
        pos_ = base + off;
        return aiReturn_SUCCESS;
    }
    size_t Tell() const override { return pos_; }
    size_t FileSize() const override { return n_; }
    void Flush() override {}

private:
    std::vector<unsigned char> own_;
    const unsigned char *p_;
    size_t n_, pos_ = 0;
};

/* The file itself from memory; other files from disk (regular files only)
 * when disk is set. Read only. */
class MemIO : public Assimp::IOSystem {
public:
    MemIO(std::string name, const unsigned char *p, size_t n, bool disk)
        : name_(std::move(name)), p_(p), n_(n), disk_(disk)
    {
    }
    bool Exists(const char *file) const override
    {
        if (!file) return false;
        if (name_ == file) return true;
        struct stat sb;
        return disk_ && stat(file, &sb) == 0 && S_ISREG(sb.st_mode);
    }
    char getOsSeparator() const override { return '/'; }
    Assimp::IOStream *Open(const char *file, const char *mode) override
    {
        if (!file || !mode || std::strchr(mode, 'w') || std::strchr(mode, 'a') || std::strchr(mode, '+'))
            return nullptr;
        if (name_ == file) return new MemStream(p_, n_, {});
        if (!disk_) return nullptr;
        struct stat sb;
        const char *why = nullptr;
        int fd = clvox__open_regular_read(file, &sb, &why);
        if (fd < 0) {
            refused_ = std::string(file) + ": " + (why ? why : "cannot open");
            return nullptr;
        }
        std::vector<unsigned char> buf;
        size_t n = (size_t)sb.st_size, done = 0;
        try {
            buf.resize(n ? n : 1);
        } catch (...) {
            close(fd);
            throw;
        }
        while (done < n) {
            ssize_t got = read(fd, buf.data() + done, n - done);
            if (got <= 0) break;
            done += (size_t)got;
        }
        close(fd);
        if (done != n) {
            refused_ = std::string(file) + ": changed size while read";
            return nullptr;
        }
        extra_bytes_ += n;
        return new MemStream(nullptr, n, std::move(buf));
    }
    void Close(Assimp::IOStream *s) override { delete s; }
    size_t extra_bytes() const { return extra_bytes_; }
    /* why the last file it could not open failed ("" if none) */
    const std::string &refused() const { return refused_; }

private:
    std::string name_;
    const unsigned char *p_;
    size_t n_;
    bool disk_;
    size_t extra_bytes_ = 0;
    std::string refused_;
};

void set_err(char *err, size_t size, const char *msg)
{
    if (err && size) std::snprintf(err, size, "%s", msg);
}

/* Growable malloc'ed array, handed to C as is. */
template <typename T> struct Buf {
    T *data = nullptr;
    size_t size = 0;
    ~Buf() { std::free(data); }
    void resize(size_t n)
    {
        if (n > SIZE_MAX / sizeof(T)) throw std::bad_alloc();
        T *p = static_cast<T *>(std::malloc((n ? n : 1) * sizeof(T)));
        if (!p) throw std::bad_alloc();
        data = p;
        size = n;
    }
    T *release()
    {
        T *p = data;
        data = nullptr;
        return p;
    }
};

struct Mat {
    double m[4][4];
};

Mat mul(const Mat &a, const aiMatrix4x4 &b)
{
    const ai_real *bb = &b.a1; /* row-major a1..d4 */
    Mat r;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double s = 0;
            for (int k = 0; k < 4; k++) s += a.m[i][k] * (double)bb[4 * k + j];
            r.m[i][j] = s;
        }
    return r;
}

struct Placement {
    const aiMesh *mesh;
    uint32_t index;
    Mat world;
};

/* Metres per unit, where the scene's metadata or its format states them. */
double unit_metres(const aiScene *s, const char *ext)
{
    std::string e(ext);
    for (auto &c : e) c = (char)(c | 0x20);
    if (e == "gltf" || e == "glb") return 1.0; /* glTF 2.0: metres, by the specification */
    if (s->mMetaData) {
        double d = 0;
        float f = 0;
        if (s->mMetaData->Get("UnitScaleFactor", d) && d > 0 && d < 1e30) return d / 100.0;
        if (s->mMetaData->Get("UnitScaleFactor", f) && f > 0 && f < 1e30f) {
            /* the file holds a double, Assimp 5.2 keeps a float: its shortest
             * decimal (2.54f -> 2.54, not 2.5399999618530273) */
            char text[32];
            for (int digits = 6; digits <= 9; digits++) {
                std::snprintf(text, sizeof text, "%.*g", digits, (double)f);
                if (std::strtof(text, nullptr) == f) break;
            }
            return std::strtod(text, nullptr) / 100.0;
        }
    }
    return 0;
}

/* A float's bits with -0 as +0: a total order (NaN too) for sorting. */
uint32_t key(float f)
{
    if (f == 0.0f) f = 0.0f;
    uint32_t u;
    std::memcpy(&u, &f, sizeof u);
    return u;
}

/* rm[v]: the index of vertex v's position among un, the mesh's distinct
 * positions (by bits) in order of first appearance. */
void weld(const aiMesh *m, std::vector<uint32_t> &rm, std::vector<uint32_t> &un)
{
    unsigned n = m->mNumVertices;
    std::vector<uint32_t> order(n);
    for (unsigned v = 0; v < n; v++) order[v] = v;
    auto k = [m](uint32_t v) {
        const aiVector3D &q = m->mVertices[v];
        return std::make_tuple(key(q.x), key(q.y), key(q.z));
    };
    std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return k(a) < k(b); });
    std::vector<uint32_t> first(n); /* per vertex: the first vertex with its position */
    for (unsigned i = 0; i < n; i++)
        first[order[i]] = i > 0 && k(order[i]) == k(order[i - 1]) ? first[order[i - 1]] : order[i];
    rm.assign(n, 0);
    un.clear();
    for (unsigned v = 0; v < n; v++) {
        if (first[v] == v) {
            rm[v] = (uint32_t)un.size();
            un.push_back(v);
        } else {
            rm[v] = rm[first[v]];
        }
    }
}

std::mutex g_lock; /* some Assimp readers keep static state */

int read_scene(const char *path, const char *ext, const unsigned char *data, size_t n, clvox__raw_mesh *out,
               char *err, size_t err_size)
{
    std::lock_guard<std::mutex> guard(g_lock);
    std::string name = path ? std::string(path) : std::string("clvox-input.") + ext;
    if (path && clvox__hooks()->assimp_crash[0] && std::strstr(path, clvox__hooks()->assimp_crash))
        std::raise(SIGSEGV); /* test hook: a reader bug that kills the process */

    Assimp::Importer imp;
    MemIO *io = new MemIO(name, data, n, path != nullptr);
    imp.SetIOHandler(io); /* owned by imp from here */
    imp.SetPropertyBool(AI_CONFIG_IMPORT_FBX_PRESERVE_PIVOTS, false);
    imp.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, 0);
    const aiScene *s = imp.ReadFile(name, aiProcess_Triangulate | aiProcess_SortByPType |
                                              aiProcess_ValidateDataStructure);
    if (!s) {
        const char *why = imp.GetErrorString();
        std::string msg = std::string("Assimp: ") + (why && *why ? why : "cannot read the file");
        if (!io->refused().empty()) msg += " (" + io->refused() + ")"; /* e.g. a buffer that is a FIFO */
        for (auto &c : msg)
            if (c == '\n' || c == '\r') c = ' ';
        set_err(err, err_size, msg.c_str());
        return -1;
    }
    if (!s->mRootNode || (s->mFlags & AI_SCENE_FLAGS_INCOMPLETE)) {
        set_err(err, err_size, "Assimp: the file holds no complete scene");
        return -1;
    }

    /* The node tree, walked with an explicit stack: a tree of N nodes has
     * at most N visits; more means a cycle. */
    uint64_t unique_bytes = 0;
    for (unsigned i = 0; i < s->mNumMeshes; i++) {
        const aiMesh *m = s->mMeshes[i];
        if (m) unique_bytes += 12ull * m->mNumVertices + 12ull * m->mNumFaces;
    }
    const uint64_t bound = (64ull << 20) + 256ull * (unique_bytes + n + io->extra_bytes());
    std::vector<Placement> place;
    struct Item {
        const aiNode *node;
        Mat world;
        unsigned depth;
    };
    Mat id{};
    for (int i = 0; i < 4; i++) id.m[i][i] = 1;
    std::vector<Item> stack;
    stack.push_back({s->mRootNode, id, 0});
    uint64_t visits = 0, max_visits = 1u << 24;
    uint64_t lines = 0, points = 0, nv = 0, nt = 0;
    while (!stack.empty()) {
        Item it = stack.back();
        stack.pop_back();
        if (++visits > max_visits || it.depth > 10000) {
            set_err(err, err_size, "the scene's node tree is too deep or has a cycle");
            return -1;
        }
        Mat w = mul(it.world, it.node->mTransformation);
        for (unsigned k = 0; k < it.node->mNumMeshes; k++) {
            unsigned mi = it.node->mMeshes[k];
            if (mi >= s->mNumMeshes || !s->mMeshes[mi]) {
                set_err(err, err_size, "a node references a mesh that does not exist");
                return -1;
            }
            const aiMesh *m = s->mMeshes[mi];
            if (!(m->mPrimitiveTypes & (aiPrimitiveType_TRIANGLE | aiPrimitiveType_POLYGON))) {
                if (m->mPrimitiveTypes & aiPrimitiveType_LINE) lines += m->mNumFaces;
                else points += m->mNumFaces;
                continue;
            }
            nv += m->mNumVertices;
            nt += m->mNumFaces;
            if (12 * nv + 12 * nt > bound) {
                char msg[256];
                std::snprintf(msg, sizeof msg,
                              "the flattened scene (%llu vertices, %llu triangles so far) exceeds the bound for "
                              "a file of this size (%llu bytes)",
                              (unsigned long long)nv, (unsigned long long)nt, (unsigned long long)bound);
                set_err(err, err_size, msg);
                return -1;
            }
            place.push_back({m, mi, w});
        }
        for (unsigned c = it.node->mNumChildren; c-- > 0;) /* reversed: children come off in file order */
            if (it.node->mChildren[c]) stack.push_back({it.node->mChildren[c], w, it.depth + 1});
    }
    if (nv > UINT32_MAX) {
        set_err(err, err_size, "the flattened scene has more than 2^32 vertices");
        return -2;
    }

    /* Vertices at exactly the same position within a mesh are one vertex
     * (Assimp's DAE and 3DS readers, and glTF files with split normals or
     * UVs, repeat them per corner): the voxels do not change, and a closed
     * surface is reported closed, as the same triangles in an OBJ are. */
    std::vector<std::vector<uint32_t>> remap(s->mNumMeshes), uniq(s->mNumMeshes);
    nv = 0;
    for (const Placement &p : place) {
        std::vector<uint32_t> &rm = remap[p.index], &un = uniq[p.index];
        if (rm.empty() && p.mesh->mNumVertices) weld(p.mesh, rm, un);
        nv += un.size();
    }
    Buf<float> xyz;
    Buf<uint32_t> idx, src;
    xyz.resize(3 * nv);
    idx.resize(3 * nt);
    src.resize(nt);
    double offset[3] = {0, 0, 0};
    size_t v0 = 0, f0 = 0;
    bool first = true;
    for (const Placement &p : place) {
        const aiMesh *m = p.mesh;
        const std::vector<uint32_t> &rm = remap[p.index], &un = uniq[p.index];
        for (size_t v = 0; v < un.size(); v++) {
            const aiVector3D &q = m->mVertices[un[v]];
            double x = q.x, y = q.y, z = q.z, r[3];
            for (int a = 0; a < 3; a++)
                r[a] = p.world.m[a][0] * x + p.world.m[a][1] * y + p.world.m[a][2] * z + p.world.m[a][3];
            if (first) {
                for (int a = 0; a < 3; a++) offset[a] = std::isfinite(r[a]) ? r[a] : 0.0;
                first = false;
            }
            for (int a = 0; a < 3; a++) xyz.data[3 * (v0 + v) + a] = (float)(r[a] - offset[a]);
        }
        for (unsigned f = 0; f < m->mNumFaces; f++) {
            const aiFace &face = m->mFaces[f];
            uint32_t *t = idx.data + 3 * (f0 + f);
            if (face.mNumIndices != 3 || !face.mIndices) { /* SortByPType + Triangulate: cannot happen */
                set_err(err, err_size, "Assimp returned a face that is not a triangle");
                return -1;
            }
            for (int c = 0; c < 3; c++) {
                unsigned i = face.mIndices[c];
                /* out of range: left for mesh_build.c to report (as an index past the vertices) */
                t[c] = i < m->mNumVertices ? (uint32_t)(v0 + rm[i]) : UINT32_MAX;
            }
            src.data[f0 + f] = p.index;
        }
        v0 += un.size();
        f0 += m->mNumFaces;
    }
    std::memset(out, 0, sizeof *out);
    out->vertex_count = (size_t)nv;
    out->face_count = (size_t)nt;
    out->index_count = 3 * (size_t)nt;
    for (int a = 0; a < 3; a++) out->offset[a] = offset[a];
    out->source.size = sizeof out->source;
    std::snprintf(out->source.reader, sizeof out->source.reader, "assimp");
    out->source.meshes = s->mNumMeshes;
    out->source.placements = place.size();
    out->source.ignored_lines = lines;
    out->source.ignored_points = points;
    out->source.unit_metres = unit_metres(s, ext);
    out->xyz = xyz.release();
    out->face_indices = idx.release();
    out->face_source = src.release();
    return 0;
}

} // namespace

extern "C" int clvox__assimp_supports(const char *ext)
{
    try {
        if (!ext || !*ext || std::strlen(ext) > 15) return 0;
        std::string e = std::string(".") + ext;
        for (auto &c : e) c = (char)(c | 0x20);
        Assimp::Importer imp;
        return imp.IsExtensionSupported(e) ? 1 : 0;
    } catch (...) {
        return 0;
    }
}

extern "C" int clvox__assimp_read(const char *path, const char *ext, const unsigned char *data, size_t n,
                                  clvox__raw_mesh *out, char *err, size_t err_size)
{
    std::memset(out, 0, sizeof *out);
    if (err && err_size) err[0] = 0;
    try {
        return read_scene(path, ext, data, n, out, err, err_size);
    } catch (const std::bad_alloc &) {
        clvox__raw_mesh_free(out);
        set_err(err, err_size, "out of memory in Assimp");
        return -2;
    } catch (const std::exception &e) {
        clvox__raw_mesh_free(out);
        std::string msg = std::string("Assimp: ") + e.what();
        set_err(err, err_size, msg.c_str());
        return -1;
    } catch (...) {
        clvox__raw_mesh_free(out);
        set_err(err, err_size, "Assimp: unknown exception");
        return -1;
    }
}
