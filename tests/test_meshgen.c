/* SPDX-License-Identifier: Apache-2.0 */
/* The test mesh generators: closed, oriented, exact volumes, writers, voxel-count
 * helper and point oracle. Uses no OpenCL. */
#include "test.h"
#include "meshgen.h"
#include <math.h>
#include <string.h>
#include <sys/stat.h>

#define PI 3.14159265358979323846
static double rel(double a, double b) { return fabs(a - b) / fabs(b); }
static long fsize(const char *path) { struct stat st; return stat(path, &st) ? -1 : (long)st.st_size; }
static int inside(const tmesh *m, double x, double y, double z)
{
    double p[3] = {x, y, z};
    return tmesh_point_inside(m, p);
}
static uint64_t hash(const tmesh *m) /* FNV-1a over the coordinate bits and indices */
{
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < 12 * m->nv; i++) h = (h ^ ((const unsigned char *)m->xyz)[i]) * 1099511628211ull;
    for (size_t i = 0; i < 12 * m->nt; i++) h = (h ^ ((const unsigned char *)m->tri)[i]) * 1099511628211ull;
    return h;
}
/* Checks that m is closed with nv vertices (0: any) and nt triangles; frees it, returns its volume. */
static double closed_volume(tmesh m, size_t nv, size_t nt)
{
    CHECK_MSG(tmesh_is_closed(&m) && (!nv || m.nv == nv) && m.nt == nt, "nv %zu nt %zu", m.nv, m.nt);
    double v = tmesh_volume(&m);
    tmesh_free(&m);
    return v;
}

static void test_exact_solids(void)
{
    const double a[3] = {0, 0, 0}, b[3] = {2, 0, 0}, c[3] = {0, 3, 0}, d[3] = {0, 0, 4};
    CHECK(closed_volume(tmesh_box(1, 2, 3, 4, 6, 8), 8, 12) == 60.0);
    for (unsigned n = 1; n <= 7; n += 3) /* dyadic coordinates: exact */
        CHECK(closed_volume(tmesh_box_subdivided(-1.5, 0.25, 2, 2.5, 1.25, 4, n), 6 * n * n + 2, 12 * n * n)
              == 8.0);
    CHECK(closed_volume(tmesh_tetra(a, b, c, d), 4, 4) == 4.0);
    CHECK(closed_volume(tmesh_tetra(b, a, c, d), 4, 4) == 4.0); /* negative order: fixed */
    CHECK(closed_volume(tmesh_octahedron(1, 1, 1, 1.5), 6, 8) == 4.5);
    tmesh m = tmesh_box_subdivided(0, 0, 0, 4, 4, 4, 4);
    int lattice = 1;
    for (size_t i = 0; i < 3 * m.nv; i++) lattice &= m.xyz[i] == floorf(m.xyz[i]);
    tmesh_translate(&m, 0.5, -1, 2);
    CHECK(lattice && m.xyz[0] == 0.5f && !inside(&m, 0.4, 0, 3) && inside(&m, 0.6, -0.9, 2.1));
    tmesh_flip(&m);
    CHECK(closed_volume(m, 98, 192) == -64.0);
    m = tmesh_octahedron(1, 1, 1, 1.5);
    CHECK(inside(&m, 1.4, 0.6, 1.2) && !inside(&m, 1.9, 0.4, 1.3));
    tmesh_free(&m);
}

/* Sphere: a regular 2n-gon has area sinc(pi/n) pi rho^2 and the meridian polygon holds
 * the half disc of radius r cos(pi/2n), so sinc(pi/n) cos^3(pi/2n) <= V / V_ball <= 1.
 * Torus: V / V_torus = sinc(2pi/nu) sinc(2pi/nv) >= 1 - ((2pi/nu)^2 + (2pi/nv)^2) / 6. */
static void test_curved(void)
{
    double prev = 1;
    for (unsigned n = 8; n <= 32; n *= 2) {
        double v = closed_volume(tmesh_sphere(0.5, -2, 3, 1.25, n), 2 + 2 * n * (n - 1), 4 * n * (n - 1));
        double err = 1 - v / tmesh_sphere_volume(1.25), x = PI / n;
        CHECK_MSG(rel(v, tmesh_sphere_poly_volume(1.25, n)) < 1e-6, "n=%u V=%.9g", n, v);
        CHECK_MSG(err > 0 && err <= 1 - sin(x) / x * pow(cos(x / 2), 3), "n=%u err %g", n, err);
        CHECK(err < prev / 3 && (n < 16 || err < 0.02)); /* O(1/n^2) */
        prev = err;
    }
    for (unsigned nu = 16, nv = 8; nu <= 64; nu *= 2, nv *= 2) {
        double v = closed_volume(tmesh_torus(1, 2, 3, 2.0, 0.5, nu, nv), nu * nv, 2 * nu * nv);
        double err = 1 - v / tmesh_torus_volume(2.0, 0.5), a = 2 * PI / nu, b = 2 * PI / nv;
        CHECK_MSG(rel(v, tmesh_torus_poly_volume(2.0, 0.5, nu, nv)) < 1e-6, "V=%.9g", v);
        CHECK_MSG(err > 0 && err <= (a * a + b * b) / 6 && (nu < 64 || err < 0.02), "err %g", err);
    }
    tmesh m = tmesh_torus(1, 2, 3, 2.0, 0.5, 16, 8);
    CHECK(!inside(&m, 1, 2, 3) && inside(&m, 3.01, 2.02, 3.03));
    tmesh_free(&m);
    m = tmesh_hollow_sphere(0, 0, 0, 2, 1, 12);
    CHECK(!inside(&m, 0.01, 0.02, 0.03) && inside(&m, 1.5, 0.01, 0.02));
    double shell = tmesh_sphere_poly_volume(2, 12) - tmesh_sphere_poly_volume(1, 12);
    CHECK(rel(closed_volume(m, 0, 2 * 4 * 12 * 11), shell) < 1e-6);
    m = tmesh_sphere(0, 0, 0, 1, 16);
    int agree = 1, tested = 0; /* oracle vs the ball, away from the polyhedral band */
    for (int i = 0; i < 13 * 13 * 13; i++) {
        double x = i % 13 / 5.0 - 1.187, y = i / 13 % 13 / 5.0 - 1.193, z = i / 169 / 5.0 - 1.197;
        double r = sqrt(x * x + y * y + z * z);
        if (r < 0.97 || r > 1.01) { agree &= inside(&m, x, y, z) == (r < 1); tested++; }
    }
    CHECK(agree && tested > 1000);
    tmesh_free(&m);
}

static void test_random(void)
{
    uint64_t s = 0;
    double c1[3], c2[3], sum = 0;
    CHECK(tmesh_rng_next(&s) == 0xe220a8397b1dcdafull); /* splitmix64 reference value */
    tmesh a = tmesh_random_closed(42, 8, 3), b = tmesh_random_closed(42, 8, 3);
    tmesh c = tmesh_random_closed(43, 8, 3);
    CHECK(a.nt == 8 * 108 && tmesh_is_closed(&a) && hash(&a) == hash(&b) && hash(&a) != hash(&c));
    int ok = 1;
    for (size_t i = 0; i < 3 * a.nv; i++) ok &= a.xyz[i] > 0 && a.xyz[i] < 1;
    for (unsigned k = 0; k < 8; k++) { /* each shell holds a ball of radius 0.1 */
        tmesh sh = {a.xyz, a.nv, 0, a.tri + 3 * 108 * k, 108, 0};
        sum += tmesh_volume(&sh);
        ok &= tmesh_volume(&sh) > 4.18e-3;
    }
    CHECK(ok && rel(tmesh_volume(&a), sum) < 1e-9);
    tmesh_free(&a); tmesh_free(&b); tmesh_free(&c);
    a = tmesh_random_closed(1, 3, 2); /* golden value: pure IEEE arithmetic, same everywhere */
    CHECK_MSG(hash(&a) == 0x6555be9656d88e61ull, "hash %016llx", (unsigned long long)hash(&a));
    tmesh_free(&a);
    a = tmesh_random_overlap(7, 3, c1, c2);
    CHECK(tmesh_is_closed(&a) && a.nt == 2 * 108 && !inside(&a, 0.999, 0.001, 0.5));
    CHECK(!inside(&a, (c1[0] + c2[0]) / 2, (c1[1] + c2[1]) / 2, (c1[2] + c2[2]) / 2)); /* even parity */
    CHECK(inside(&a, 1.5 * c1[0] - 0.5 * c2[0], 1.5 * c1[1] - 0.5 * c2[1], 1.5 * c1[2] - 0.5 * c2[2]));
    a.nt--; /* a hole */
    CHECK(!tmesh_is_closed(&a));
    tmesh_free(&a);
}

static void test_writers(void)
{
    char p[4][1024], line[128];
    const char *ext[4] = {"stl", "ply", "off", "obj"};
    long head = 0, lines[4] = {0};
    for (int i = 0; i < 4; i++) snprintf(p[i], sizeof p[i], "%s/meshgen.%s", test_tmpdir(), ext[i]);
    tmesh m = tmesh_sphere(0, 0, 0, 1, 6);
    CHECK(tmesh_write_stl_binary(&m, p[0]) == 0 && fsize(p[0]) == 84 + 50 * (long)m.nt);
    CHECK(tmesh_write_ply_binary(&m, p[1]) == 0 && tmesh_write_off(&m, p[2]) == 0);
    CHECK(tmesh_write_obj(&m, p[3]) == 0);
    FILE *f = fopen(p[1], "rb");
    while (f && fgets(line, sizeof line, f) && (head += (long)strlen(line)) && strcmp(line, "end_header\n")) {}
    if (f) fclose(f);
    CHECK(fsize(p[1]) == head + 12 * (long)m.nv + 13 * (long)m.nt);
    for (int i = 2; i < 4 && (f = fopen(p[i], "r")) != NULL; fclose(f), i++)
        for (int ch; (ch = fgetc(f)) != EOF;) lines[i] += ch == '\n';
    CHECK(lines[2] == 2 + (long)(m.nv + m.nt) && lines[3] == (long)(m.nv + m.nt));
    CHECK(tmesh_write_off(&m, "/nonexistent-dir/x.off") != 0);
    tmesh_free(&m);
}

static void test_expected_voxels(void)
{
    clvox_grid g = {{10, 10, 10}, {0, 0, 0}, {1, 1, 1}}, an = {{8, 8, 4}, {-1, 0, 2}, {0.5, 0.25, 2}};
    const double lo[6][3] = {{2, 2, 2}, {2.5, 2.5, 2.5}, {-3, -3, -3}, {2, 2, 2}, {5, 5, 5}, {-1, 0.125, 3}};
    const double hi[6][3] = {{5, 5, 5}, {5.5, 5.5, 5.5}, {99, 99, 99}, {2.4, 9, 9}, {2, 2, 2}, {0.25, 1, 6}};
    /* centres 2.5 3.5 4.5 (5.5 excluded); last, on `an`: x -0.75 -0.25 (not 0.25), y 0.125..0.875, z 3 5 */
    const uint64_t want[6] = {27, 27, 1000, 0, 0, 2 * 4 * 2};
    for (int i = 0; i < 6; i++)
        CHECK_MSG(expected_box_voxels(i < 5 ? &g : &an, lo[i], hi[i]) == want[i], "case %d", i);
    const double blo[3] = {0.3, 1.1, 2.9}, bhi[3] = {2.7, 7.35, 6.2}; /* against the oracle */
    tmesh m = tmesh_box(blo[0], blo[1], blo[2], bhi[0], bhi[1], bhi[2]);
    uint64_t brute = 0;
    for (int i = 0; i < 1000; i++) /* x 0.5..2.5, y 1.5..6.5, z 3.5..5.5 */
        brute += (uint64_t)inside(&m, i % 10 + 0.5, i / 10 % 10 + 0.5, i / 100 + 0.5);
    CHECK_MSG(brute == expected_box_voxels(&g, blo, bhi) && brute == 3 * 6 * 3, "%lu", (unsigned long)brute);
    tmesh_free(&m);
}

int main(void)
{
    test_exact_solids();
    test_curved();
    test_random();
    test_writers();
    test_expected_voxels();
    return test_report();
}
