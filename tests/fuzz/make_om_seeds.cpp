/* SPDX-License-Identifier: Apache-2.0 */
// Writes the OM seeds of fuzz_mesh_om with OpenMesh itself (OM 2.2, as
// OpenMesh 9.0 writes it): a tetrahedron as a TriMesh, the unit cube as a
// PolyMesh (quads), the tetrahedron with vertex normals.
//   c++ -std=c++17 tests/fuzz/make_om_seeds.cpp -lOpenMeshCore -o /tmp/make_om_seeds && /tmp/make_om_seeds tests/fuzz/seeds_mesh_om
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <string>
#include <vector>

typedef OpenMesh::TriMesh_ArrayKernelT<> Tri;
typedef OpenMesh::PolyMesh_ArrayKernelT<> Poly;

int main(int argc, char **argv)
{
    std::string dir = argc > 1 ? argv[1] : ".";
    {
        Tri m;
        std::vector<Tri::VertexHandle> v;
        const float p[4][3] = {{0, 0, 0}, {2, 0, 0}, {0, 3, 0}, {0, 0, 4}};
        for (auto &q : p) v.push_back(m.add_vertex(Tri::Point(q[0], q[1], q[2])));
        const int t[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
        for (auto &f : t) m.add_face(v[f[0]], v[f[1]], v[f[2]]);
        if (!OpenMesh::IO::write_mesh(m, dir + "/tetra_tri.om")) return 1;
        m.request_vertex_normals();
        m.update_normals();
        if (!OpenMesh::IO::write_mesh(m, dir + "/tetra_normals.om", OpenMesh::IO::Options::VertexNormal)) return 1;
    }
    {
        Poly m;
        std::vector<Poly::VertexHandle> v;
        const float p[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
        for (auto &q : p) v.push_back(m.add_vertex(Poly::Point(q[0], q[1], q[2])));
        const int q[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
        for (auto &f : q) m.add_face(std::vector<Poly::VertexHandle>{v[f[0]], v[f[1]], v[f[2]], v[f[3]]});
        if (!OpenMesh::IO::write_mesh(m, dir + "/cube_poly.om")) return 1;
    }
    return 0;
}
