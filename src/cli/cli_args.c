/* SPDX-License-Identifier: Apache-2.0 */
/*
 * The options of `clvox MESH` and `clvox batch`: the strict number parsers,
 * parse_args (every option and the combinations refused), grid_option_parse
 * (the per-mesh grid of a batch manifest, same rules) and print_help, the
 * text that documents them. Split from cli.c unchanged, kept together so an
 * option and its documentation are read and changed in one place.
 */
#include "clvox.h"
#include "cli_common.h"
#include "cli_vox.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- strict number parsing ---------------------------------------------- */

static const char *parse_double(const char *s, int positive, double *out, const char **end_out)
{
    if (!s || *s == '\0') return "empty value";
    if (!((*s >= '0' && *s <= '9') || *s == '-' || *s == '+' || *s == '.')) return "not a number";
    if (positive && *s == '-') return "must be positive";
    errno = 0;
    char *end = NULL;
    double v = strtod(s, &end);
    if (end == s) return "not a number";
    if (end_out) *end_out = end;
    else if (*end != '\0') return "not a number";
    if (errno == ERANGE || !isfinite(v)) return "out of range";
    if (positive && !(v > 0)) return "must be positive";
    *out = v;
    return NULL;
}

/* Comma-separated list of exactly `n` values. */
/* Strict decimal uint64. */
static const char *parse_u64(const char *s, uint64_t *out)
{
    if (!s || *s == '\0') return "empty value";
    for (const char *p = s; *p; p++)
        if (*p < '0' || *p > '9') return "not a non-negative integer";
    errno = 0;
    char *end = NULL;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno == ERANGE || *end != '\0') return "out of range (at most 18446744073709551615)";
    *out = (uint64_t)v;
    return NULL;
}

/* "occupancy,coverage,element,score" -> CLVOX_CHANNEL_* mask. */
static const char *parse_channels(const char *s, uint32_t *out)
{
    uint32_t mask = 0;
    while (*s) {
        size_t n = strcspn(s, ",");
        if (n == 9 && strncmp(s, "occupancy", 9) == 0) mask |= CLVOX_CHANNEL_OCCUPANCY;
        else if (n == 8 && strncmp(s, "coverage", 8) == 0) mask |= CLVOX_CHANNEL_COVERAGE;
        else if (n == 7 && strncmp(s, "element", 7) == 0) mask |= CLVOX_CHANNEL_ELEMENT;
        else if (n == 5 && strncmp(s, "score", 5) == 0) mask |= CLVOX_CHANNEL_SCORE;
        else return "unknown channel";
        s += n;
        if (*s == ',' && *++s == '\0') return "empty channel name";
    }
    if (!mask) return "no channel";
    *out = mask;
    return NULL;
}

static const char *parse_u32_list(const char *s, uint32_t min, uint32_t *out, int n)
{
    for (int i = 0; i < n; i++) {
        const char *end = NULL;
        const char *why = parse_u32(s, min, &out[i], &end);
        if (why) return why;
        if (i + 1 < n) {
            if (*end != ',') return "too few values";
            s = end + 1;
        } else if (*end != '\0') {
            return *end == ',' ? "too many values" : "not a non-negative integer";
        }
    }
    return NULL;
}

/* Parses 1..max doubles; *count receives how many. */
static const char *parse_double_list(const char *s, int positive, double *out, int max, int *count)
{
    int i = 0;
    for (;;) {
        if (i == max) return "too many values";
        const char *end = NULL;
        const char *why = parse_double(s, positive, &out[i], &end);
        if (why) return why;
        i++;
        if (*end == '\0') break;
        if (*end != ',') return "not a number";
        s = end + 1;
    }
    *count = i;
    return NULL;
}

/* ---- arguments ------------------------------------------------------------ */


static int set_grid_kind(cli_args *a, int kind, const char *name)
{
    int k = kind == GRID_BY_RESOLUTION ? 0 : kind == GRID_BY_DIMS ? 1 : 2;
    for (int j = 0; j < 3; j++) {
        if (j != k && a->grid_opt[j])
            return usage_error("%s and %s can not be combined: give one of -r, --dims, --voxel-size",
                               a->grid_opt[j], name);
    }
    a->grid_by = kind;
    a->grid_opt[k] = name;
    a->grid.resolution = 0;
    memset(a->grid.dims, 0, sizeof a->grid.dims);
    memset(a->grid.voxel_size, 0, sizeof a->grid.voxel_size);
    return 0;
}

int parse_args(int argc, char **argv, int first, int multi, cli_extra_opt_fn extra, void *user, cli_args *a)
{
    clvox_grid_options g0 = CLVOX_GRID_OPTIONS_INIT;
    clvox_voxelize_options v0 = CLVOX_VOXELIZE_OPTIONS_INIT;
    memset(a, 0, sizeof *a);
    a->grid = g0;
    a->vox = v0;
    clvox_output_options o0 = CLVOX_OUTPUT_OPTIONS_INIT;
    a->out = o0;
    int options_done = 0;

    for (int i = first; i < argc; i++) {
        const char *arg = argv[i];
        const char *v = NULL;
        const char *why = NULL;
        int missing = 0;

        if (options_done || arg[0] != '-' || arg[1] == '\0') {
            if (multi) {
                const char **grown = realloc(a->meshes, (a->mesh_count + 1) * sizeof *grown);
                if (!grown) return fail(EXIT_RUNTIME, "out of memory");
                a->meshes = grown;
                a->meshes[a->mesh_count++] = arg;
                continue;
            }
            if (a->mesh)
                return usage_error("more than one mesh given: '%s' and '%s' (clvox batch voxelizes several)",
                                   a->mesh, arg);
            a->mesh = arg;
            continue;
        }
        if (strcmp(arg, "--") == 0) {
            options_done = 1;
            continue;
        }
        if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) { a->help = 1; continue; }
        if (strcmp(arg, "-V") == 0 || strcmp(arg, "--version") == 0) { a->version = 1; continue; }
        if (strcmp(arg, "-q") == 0 || strcmp(arg, "--quiet") == 0) { a->quiet = 1; continue; }
        if (strcmp(arg, "--no-progress") == 0) { a->no_progress = 1; continue; }
        if (strcmp(arg, "--float-kernels") == 0) { a->float_kernels = 1; continue; }
        if (strcmp(arg, "--list-devices") == 0) { a->list_devices = 1; continue; }
        if (strcmp(arg, "--npy-bits") == 0) { a->out.flags |= CLVOX_OUTPUT_PACK_BITS; continue; }
        if (strcmp(arg, "--npy-float32") == 0) { a->out.flags |= CLVOX_OUTPUT_FLOAT32; continue; }
        if (strcmp(arg, "--npy-uint32") == 0) { a->out.flags |= CLVOX_OUTPUT_UINT32; continue; }
        if (strcmp(arg, "--json") == 0) { a->json = 1; continue; }
        if (strcmp(arg, "--cube") == 0) { a->grid.cube = 1; continue; }

#define VALUE_OPT(sn, ln) match_value(argc, argv, &i, (sn), (ln), &v, &missing)
#define NEED_VALUE(name) \
    do { if (missing) return usage_error("option %s needs a value", (name)); } while (0)

        if (VALUE_OPT("-o", "--output")) {
            NEED_VALUE("-o");
            if (*v == '\0') return usage_error("-o: empty file name");
            a->output = v;
        } else if (VALUE_OPT(NULL, "--format")) {
            NEED_VALUE("--format");
            if ((a->out.format = clvox_format_from_name(v)) == CLVOX_FORMAT_AUTO)
                return usage_error("--format '%s': one of exr, npy, nrrd, binvox, vdb", v);
        } else if (VALUE_OPT("-r", "--resolution")) {
            NEED_VALUE("-r");
            if (set_grid_kind(a, GRID_BY_RESOLUTION, "-r")) return EXIT_USAGE;
            if ((why = parse_u32(v, 1, &a->grid.resolution, NULL)))
                return usage_error("-r '%s': %s", v, why);
        } else if (VALUE_OPT(NULL, "--dims")) {
            NEED_VALUE("--dims");
            if (set_grid_kind(a, GRID_BY_DIMS, "--dims")) return EXIT_USAGE;
            if ((why = parse_u32_list(v, 1, a->grid.dims, 3)))
                return usage_error("--dims '%s': %s (expected X,Y,Z, each at least 1)", v, why);
        } else if (VALUE_OPT(NULL, "--voxel-size")) {
            NEED_VALUE("--voxel-size");
            if (set_grid_kind(a, GRID_BY_VOXEL_SIZE, "--voxel-size")) return EXIT_USAGE;
            int n = 0;
            if ((why = parse_double_list(v, 1, a->grid.voxel_size, 3, &n)) || (n != 1 && n != 3))
                return usage_error("--voxel-size '%s': %s (expected S or SX,SY,SZ, positive)", v,
                                   why ? why : "give one or three values");
            if (n == 1) a->grid.voxel_size[1] = a->grid.voxel_size[2] = a->grid.voxel_size[0];
        } else if (VALUE_OPT(NULL, "--box")) {
            NEED_VALUE("--box");
            double b[6];
            int n = 0;
            if ((why = parse_double_list(v, 0, b, 6, &n)) || n != 6)
                return usage_error("--box '%s': %s (expected x0,y0,z0,x1,y1,z1)", v,
                                   why ? why : "give six values");
            for (int k = 0; k < 3; k++) {
                if (!(b[k] < b[k + 3]))
                    return usage_error("--box '%s': the %c range is empty (%g >= %g)", v, "xyz"[k], b[k],
                                       b[k + 3]);
                a->grid.box_min[k] = b[k];
                a->grid.box_max[k] = b[k + 3];
            }
            a->grid.use_box = 1;
        } else if (VALUE_OPT(NULL, "--pad")) {
            NEED_VALUE("--pad");
            if ((why = parse_u32(v, 0, &a->grid.padding, NULL))) return usage_error("--pad '%s': %s", v, why);
            a->pad_given = 1;
        } else if (VALUE_OPT(NULL, "--like")) {
            NEED_VALUE("--like");
            if (*v == '\0') return usage_error("--like: empty file name");
            a->like = v;
        } else if (VALUE_OPT(NULL, "--method")) {
            NEED_VALUE("--method");
            if (strcmp(v, "ray") == 0) a->vox.method = CLVOX_METHOD_RAY;
            else if (strcmp(v, "tetra") == 0) a->vox.method = CLVOX_METHOD_TETRA;
            else return usage_error("--method '%s': expected ray or tetra", v);
        } else if (VALUE_OPT(NULL, "--mode")) {
            NEED_VALUE("--mode");
            if (strcmp(v, "solid") == 0) a->vox.mode = CLVOX_MODE_SOLID;
            else if (strcmp(v, "surface") == 0) a->vox.mode = CLVOX_MODE_SURFACE;
            else if (strcmp(v, "conservative") == 0) a->vox.mode = CLVOX_MODE_CONSERVATIVE;
            else return usage_error("--mode '%s': expected solid, surface or conservative", v);
        } else if (VALUE_OPT(NULL, "--inside")) {
            NEED_VALUE("--inside");
            if (strcmp(v, "winding") == 0) a->vox.inside = CLVOX_INSIDE_WINDING;
            else if (strcmp(v, "winding-abs") == 0) a->vox.inside = CLVOX_INSIDE_WINDING_ABS;
            else if (strcmp(v, "parity") == 0) a->vox.inside = CLVOX_INSIDE_PARITY;
            else return usage_error("--inside '%s': expected winding, winding-abs or parity", v);
        } else if (VALUE_OPT(NULL, "--weld")) {
            NEED_VALUE("--weld");
            if ((why = parse_double(v, 1, &a->vox.weld, NULL))) return usage_error("--weld '%s': %s", v, why);
        } else if (VALUE_OPT(NULL, "--axis")) {
            NEED_VALUE("--axis");
            if (strcmp(v, "x") == 0) a->vox.ray_axis = CLVOX_AXIS_X;
            else if (strcmp(v, "y") == 0) a->vox.ray_axis = CLVOX_AXIS_Y;
            else if (strcmp(v, "z") == 0) a->vox.ray_axis = CLVOX_AXIS_Z;
            else return usage_error("--axis '%s': expected x, y or z", v);
        } else if (VALUE_OPT(NULL, "--depth")) {
            NEED_VALUE("--depth");
            if ((why = parse_u32(v, 0, &a->vox.quadtree_max_depth, NULL)))
                return usage_error("--depth '%s': %s", v, why);
        } else if (VALUE_OPT(NULL, "--leaf")) {
            NEED_VALUE("--leaf");
            if ((why = parse_u32(v, 0, &a->vox.quadtree_leaf_size, NULL)))
                return usage_error("--leaf '%s': %s", v, why);
        } else if (VALUE_OPT(NULL, "--slab")) {
            NEED_VALUE("--slab");
            if ((why = parse_u32(v, 0, &a->vox.slab_depth, NULL))) return usage_error("--slab '%s': %s", v, why);
        } else if (VALUE_OPT(NULL, "--compression")) {
            NEED_VALUE("--compression");
            if (strcmp(v, "none") == 0) a->vox.compression = CLVOX_COMPRESSION_NONE;
            else if (strcmp(v, "rle") == 0) a->vox.compression = CLVOX_COMPRESSION_RLE;
            else if (strcmp(v, "zip") == 0) a->vox.compression = CLVOX_COMPRESSION_ZIP;
            else if (strcmp(v, "zips") == 0) a->vox.compression = CLVOX_COMPRESSION_ZIPS;
            else if (strcmp(v, "piz") == 0) a->vox.compression = CLVOX_COMPRESSION_PIZ;
            else return usage_error("--compression '%s': expected none, rle, zip, zips or piz", v);
        } else if (VALUE_OPT(NULL, "--tetra-origin")) {
            NEED_VALUE("--tetra-origin");
            if (strcmp(v, "centroid") == 0) {
                a->vox.tetra_origin = CLVOX_TETRA_ORIGIN_CENTROID;
            } else if (strcmp(v, "bbox") == 0) {
                a->vox.tetra_origin = CLVOX_TETRA_ORIGIN_BBOX_CENTER;
            } else {
                int n = 0;
                if ((why = parse_double_list(v, 0, a->vox.tetra_point, 3, &n)) || n != 3)
                    return usage_error("--tetra-origin '%s': expected centroid, bbox or x,y,z", v);
                a->vox.tetra_origin = CLVOX_TETRA_ORIGIN_POINT;
            }
        } else if (VALUE_OPT(NULL, "--palette")) {
            NEED_VALUE("--palette");
            if (*v == '\0') return usage_error("--palette: empty name");
            a->palette = v;
        } else if (VALUE_OPT(NULL, "--metric")) {
            NEED_VALUE("--metric");
            if (strcmp(v, "nearest") == 0) a->vox.metric = CLVOX_METRIC_NEAREST;
            else if (strcmp(v, "outer") == 0) a->vox.metric = CLVOX_METRIC_OUTER;
            else if (strcmp(v, "inner") == 0) a->vox.metric = CLVOX_METRIC_INNER;
            else return usage_error("--metric '%s': expected nearest, outer or inner", v);
            a->metric_given = 1;
        } else if (VALUE_OPT(NULL, "--samples")) {
            NEED_VALUE("--samples");
            uint32_t tp[2] = {0, 0};
            if ((why = parse_u32_list(v, 1, tp, 2)))
                return usage_error("--samples '%s': %s (expected T,P: T rays per voxel column, P points per voxel)", v,
                                   why);
            uint32_t n = 1;
            while ((n + 1) * (n + 1) <= tp[0]) n++;
            if (n * n != tp[0] || n > CLVOX_MAX_OVERSAMPLE)
                return usage_error("--samples '%s': T = %u rays is not the square of 1 .. %u (the rays form an N x N "
                                   "grid per voxel column: 1, 4, 9, 16, ..., 256)",
                                   v, tp[0], CLVOX_MAX_OVERSAMPLE);
            if (tp[1] > CLVOX_MAX_POINTS) return usage_error("--samples '%s': at most %u points per voxel", v, CLVOX_MAX_POINTS);
            if ((uint64_t)tp[0] * tp[1] > CLVOX_MAX_PALETTE_SAMPLES)
                return usage_error("--samples '%s': %llu samples per voxel, at most %u", v,
                                   (unsigned long long)tp[0] * tp[1], CLVOX_MAX_PALETTE_SAMPLES);
            if (a->samples_opt && strcmp(a->samples_opt, "--oversample") == 0)
                return usage_error("--samples and --oversample both set the samples: give one");
            a->samples_opt = "--samples";
            a->vox.oversample = n;
            a->vox.oversample_points = tp[1];
        } else if (strcmp(arg, "--no-early-out") == 0) {
            a->vox.palette_no_early_out = 1;
        } else if (VALUE_OPT(NULL, "--shortcut")) {
            NEED_VALUE("--shortcut");
            a->vox.nearest_shortcut = 1;
            if (strcmp(v, "auto") != 0) {
                double ab[2];
                int n = 0;
                if ((why = parse_double_list(v, 0, ab, 2, &n)) || n != 2)
                    return usage_error("--shortcut '%s': expected auto or ALPHA,BETA", v);
                if (!(ab[0] > 0 && ab[0] < ab[1] && ab[1] < 1))
                    return usage_error("--shortcut '%s': needs 0 < ALPHA < BETA < 1", v);
                a->vox.shortcut_alpha = ab[0];
                a->vox.shortcut_beta = ab[1];
            }
        } else if (VALUE_OPT(NULL, "--oversample")) {
            NEED_VALUE("--oversample");
            if (a->samples_opt && strcmp(a->samples_opt, "--samples") == 0)
                return usage_error("--samples and --oversample both set the samples: give one");
            a->samples_opt = "--oversample";
            uint32_t nm[2] = {0, 0};
            if (strchr(v, ',')) {
                if ((why = parse_u32_list(v, 1, nm, 2)))
                    return usage_error("--oversample '%s': %s (expected K or N,M, each at least 1)", v, why);
            } else if ((why = parse_u32(v, 1, &nm[0], NULL))) {
                return usage_error("--oversample '%s': %s (expected K or N,M, each at least 1)", v, why);
            }
            if (nm[0] > CLVOX_MAX_OVERSAMPLE)
                return usage_error("--oversample '%s': at most %u rays per side (%u rays per column)", v,
                                   CLVOX_MAX_OVERSAMPLE, CLVOX_MAX_OVERSAMPLE * CLVOX_MAX_OVERSAMPLE);
            if (nm[1] > CLVOX_MAX_POINTS)
                return usage_error("--oversample '%s': at most %u points per voxel", v, CLVOX_MAX_POINTS);
            uint64_t samples = (uint64_t)nm[0] * nm[0] * (nm[1] ? nm[1] : nm[0]);
            if (samples > CLVOX_MAX_SAMPLES)
                return usage_error("--oversample '%s': %llu samples per voxel, at most %u", v,
                                   (unsigned long long)samples, CLVOX_MAX_SAMPLES);
            a->vox.oversample = nm[0];
            a->vox.oversample_points = nm[1];
        } else if (strcmp(arg, "--stochastic") == 0) {
            a->vox.stochastic = 1;
        } else if (VALUE_OPT(NULL, "--seed")) {
            NEED_VALUE("--seed");
            if ((why = parse_u64(v, &a->vox.seed))) return usage_error("--seed '%s': %s", v, why);
            a->seed_given = 1;
        } else if (VALUE_OPT(NULL, "--threshold")) {
            NEED_VALUE("--threshold");
            if ((why = parse_double(v, 0, &a->vox.threshold, NULL)))
                return usage_error("--threshold '%s': %s (expected a number in [0, 1])", v, why);
            if (!(a->vox.threshold >= 0.0 && a->vox.threshold <= 1.0))
                return usage_error("--threshold '%s': outside [0, 1]", v);
            a->vox.threshold_set = 1;
        } else if (VALUE_OPT(NULL, "--channels")) {
            NEED_VALUE("--channels");
            if ((why = parse_channels(v, &a->vox.channels)))
                return usage_error("--channels '%s': %s (expected a comma-separated list of occupancy, coverage, "
                                   "element, score)",
                                   v, why);
        } else if (VALUE_OPT(NULL, "--threads")) {
            NEED_VALUE("--threads");
            if ((why = parse_u32(v, 0, &a->vox.threads, NULL))) return usage_error("--threads '%s': %s", v, why);
        } else if (VALUE_OPT(NULL, "--device")) {
            NEED_VALUE("--device");
            if (*v == '\0') return usage_error("--device: empty selector");
            a->device = v;
        } else {
            int took = extra ? extra(user, argc, argv, &i) : 0;
            if (took < 0) return EXIT_USAGE;
            if (took == 0) return usage_error("unknown option '%s'", arg);
        }
#undef VALUE_OPT
#undef NEED_VALUE
    }
    if (a->like) { /* the whole grid comes from the file */
        const char *other = a->grid_opt[0]   ? a->grid_opt[0]
                            : a->grid_opt[1] ? a->grid_opt[1]
                            : a->grid_opt[2] ? a->grid_opt[2]
                            : a->grid.use_box ? "--box"
                            : a->pad_given   ? "--pad"
                            : a->grid.cube   ? "--cube"
                                             : NULL;
        if (other)
            return usage_error("--like and %s can not be combined: --like takes the dims, origin and voxel size "
                               "from '%s'",
                               other, a->like);
    }
    /* combinations the library would also refuse, said in CLI terms */
    if (a->grid.cube && (a->grid_by & GRID_BY_DIMS) &&
        (a->grid.dims[0] != a->grid.dims[1] || a->grid.dims[0] != a->grid.dims[2]))
        return usage_error("--cube needs one size on every axis: --dims N,N,N (got %u,%u,%u)", a->grid.dims[0],
                           a->grid.dims[1], a->grid.dims[2]);
    if (a->grid.cube && (a->grid_by & GRID_BY_VOXEL_SIZE) &&
        (a->grid.voxel_size[0] != a->grid.voxel_size[1] || a->grid.voxel_size[0] != a->grid.voxel_size[2]))
        return usage_error("--cube needs cubic voxels: --voxel-size S (got %g,%g,%g)", a->grid.voxel_size[0],
                           a->grid.voxel_size[1], a->grid.voxel_size[2]);
    if (!a->palette) {
        if (a->metric_given) return usage_error("--metric needs --palette");
        if (a->samples_opt && strcmp(a->samples_opt, "--samples") == 0) return usage_error("--samples needs --palette");
        if (a->vox.palette_no_early_out) return usage_error("--no-early-out needs --palette");
        if (a->vox.nearest_shortcut) return usage_error("--shortcut needs --palette");
        if (a->vox.channels & (CLVOX_CHANNEL_ELEMENT | CLVOX_CHANNEL_SCORE))
            return usage_error("--channels element,score need --palette");
    } else {
        if (a->vox.method == CLVOX_METHOD_TETRA)
            return usage_error("--palette: palette scoring samples rays (use --method ray)");
        if (a->vox.nearest_shortcut && a->vox.metric != CLVOX_METRIC_NEAREST)
            return usage_error("--shortcut is for --metric nearest only");
        if (a->vox.oversample && (uint64_t)a->vox.oversample * a->vox.oversample *
                                         (a->vox.oversample_points ? a->vox.oversample_points : a->vox.oversample) >
                                     CLVOX_MAX_PALETTE_SAMPLES)
            return usage_error("--oversample with --palette: at most %u samples per voxel", CLVOX_MAX_PALETTE_SAMPLES);
    }
    if (!a->vox.oversample && !a->palette) {
        if (a->vox.stochastic) return usage_error("--stochastic needs --oversample");
        if (a->seed_given) return usage_error("--seed needs --oversample --stochastic");
        if (a->vox.threshold_set) return usage_error("--threshold needs --oversample (binary runs are already 0/1)");
        if (a->vox.channels & CLVOX_CHANNEL_COVERAGE) return usage_error("--channels coverage needs --oversample");
    } else if (a->vox.method == CLVOX_METHOD_TETRA) {
        return usage_error("--oversample: the tetra method does not compute coverage (use --method ray)");
    }
    if (a->seed_given && !a->vox.stochastic) return usage_error("--seed needs --stochastic");
    if (a->vox.mode != CLVOX_MODE_SOLID) {
        const char *mode = clvox_mode_name(a->vox.mode);
        if (a->palette) return usage_error("--mode %s: --palette needs --mode solid", mode);
        if (a->vox.oversample) return usage_error("--mode %s is binary: --oversample needs --mode solid", mode);
        if (a->vox.channels & ~CLVOX_CHANNEL_OCCUPANCY)
            return usage_error("--mode %s writes occupancy only", mode);
    }
    return 0;
}

const char *grid_option_parse(const char *opt, const char *value, clvox_grid_options *g, int *grid_by)
{
    static char msg[320];
    const char *why = NULL;
    g->resolution = 0;
    memset(g->dims, 0, sizeof g->dims);
    memset(g->voxel_size, 0, sizeof g->voxel_size);
    if (strcmp(opt, "-r") == 0 || strcmp(opt, "--resolution") == 0) {
        if ((why = parse_u32(value, 1, &g->resolution, NULL))) goto bad;
        *grid_by = GRID_BY_RESOLUTION;
    } else if (strcmp(opt, "--dims") == 0) {
        if ((why = parse_u32_list(value, 1, g->dims, 3))) goto bad;
        *grid_by = GRID_BY_DIMS;
    } else if (strcmp(opt, "--voxel-size") == 0) {
        int n = 0;
        if ((why = parse_double_list(value, 1, g->voxel_size, 3, &n))) goto bad;
        if (n != 1 && n != 3) {
            why = "give one or three values";
            goto bad;
        }
        if (n == 1) g->voxel_size[1] = g->voxel_size[2] = g->voxel_size[0];
        *grid_by = GRID_BY_VOXEL_SIZE;
    } else {
        snprintf(msg, sizeof msg, "unknown grid option '%s'", opt);
        return msg;
    }
    return NULL;
bad:
    snprintf(msg, sizeof msg, "%s '%.200s': %s", opt, value, why);
    return msg;
}

/* ---- help ------------------------------------------------------------------ */

void print_help(void)
{
    printf(
"Usage: clvox [MESH] [options]\n"
"       clvox batch [MESH...] [--dir DIR] [--manifest FILE] [options]\n"
"       clvox info FILE [--json]\n"
"       clvox preview FILE -o OUT.png [options]\n"
"       clvox palette list | show NAME|FILE\n"
"       clvox instances VOLUME.exr -o OUT.csv [--render-map MAP]\n"
"       clvox mesh VOLUME -o OUT.{ply,obj,stl} [--faces|--smooth] [--iso V] [--channel NAME] [--ascii]\n"
"       clvox convert IN OUT.{npy,nrrd,binvox,vdb,exr} [--format F] [--channel NAME]...\n"
"                     [--compression C] [--npy-bits] [--npy-float32] [--npy-uint32]\n"
"       clvox --list-devices | --help | --version\n"
"\n"
"Voxelizes a triangle mesh on an OpenCL device and writes the solid (inside =\n"
"1) volume to an OpenEXR file, slab by slab in bounded memory. Open, cracked,\n"
"mis-oriented and overlapping meshes too: by default a voxel is inside where\n"
"the exact generalized winding number is above 1/2 (--inside).\n"
"Meshes: OBJ, OFF, PLY (ascii/binary), STL (ascii/binary), OM, by extension;\n"
"glTF 2.0 (.gltf, .glb), 3MF, FBX, DAE, 3DS and the other formats Assimp reads,\n"
"through Assimp in a child process (scenes flattened with their node transforms).\n"
"\n"
"Input and output:\n"
"  MESH                     mesh to voxelize (default: the bundled mesh, see\n"
"                           Environment below); the mesh used is printed\n"
"  -o, --output OUT.exr     output file (default: <MESH name without extension>.exr\n"
"                           in the current directory); written to a temporary name\n"
"                           and renamed on success, so a failed run leaves no file.\n"
"                           The extension picks the format: .exr, .npy (+ OUT.json),\n"
"                           .nrrd, .binvox, .vdb (docs/formats.md)\n"
"  --format exr|npy|nrrd|binvox|vdb  the output format whatever the extension\n"
"  --npy-bits               npy occupancy packed 8 voxels per byte along x\n"
"  --npy-float32            npy coverage/score as float32 (default float16)\n"
"  --npy-uint32             npy element as uint32 (default uint16)\n"
"\n"
"Grid (at most one of -r, --dims, --voxel-size; default -r %u):\n"
"  -r, --resolution N       N voxels along the longest axis of the box, cubic\n"
"                           voxels (default %u)\n"
"  --dims X,Y,Z             voxels per axis; the box is divided evenly (voxels\n"
"                           may be non-cubic)\n"
"  --voxel-size S[,S,S]     voxel size (one value: cubic voxels); ceil(extent/S)\n"
"                           voxels per axis\n"
"  --box x0,y0,z0,x1,y1,z1  box to voxelize (default: the mesh bounding box)\n"
"  --pad N                  empty voxels added on every side (default 0)\n"
"  --cube                   a cubic grid, as binvox makes: the box (the mesh's,\n"
"                           or --box) becomes a cube around its centre, every\n"
"                           edge as long as its longest one, L; then -r N gives\n"
"                           N x N x N voxels of size L/N (--dims N,N,N and\n"
"                           --voxel-size S apply to the cube too), --pad after.\n"
"                           Automatic for .binvox outputs unless --box, --like,\n"
"                           non-cubic --dims or --voxel-size SX,SY,SZ set the grid\n"
"  --like FILE              the grid (dims, origin, voxel size) of an existing\n"
"                           volume: a clvox .exr, a NRRD (.nrrd/.nhdr, clvox's\n"
"                           or e.g. 3D Slicer's; axis-aligned, coordinates as\n"
"                           given) or a clvox .npy (its OUT.json sidecar);\n"
"                           not with -r, --dims, --voxel-size, --box, --pad or\n"
"                           --cube\n"
"  Voxel (i,j,k) covers [origin + (i,j,k)*h, origin + (i+1,j+1,k+1)*h) and is\n"
"  inside when its centre origin + (i+0.5,j+0.5,k+0.5)*h is inside the mesh.\n"
"  Limits: at most %u voxels per axis and %llu voxels in all.\n"
"\n",
        DEFAULT_RESOLUTION, DEFAULT_RESOLUTION, CLVOX_MAX_AXIS, (unsigned long long)CLVOX_MAX_VOXELS);
    fputs(
"Mode (what a voxel holds; default solid):\n"
"  --mode solid|surface|conservative\n"
"                           solid: the voxel centre is inside the mesh (see\n"
"                           --inside); surface: the voxel's closed\n"
"                           cell meets a triangle (exact: a triangle touching a\n"
"                           cell's face, edge or corner marks it, so a face on the\n"
"                           plane between two cells marks both; degenerate\n"
"                           triangles mark what they touch; no parity, so open\n"
"                           meshes and triangle soups are fine; --method and its\n"
"                           options do not apply); conservative: solid or surface\n"
"                           (solid by --method and --inside). Both are binary\n"
"                           (occupancy; no --oversample, --palette)\n"
"\n"
"Inside test (solid voxels and samples; ray method):\n"
"  --inside winding|winding-abs|parity\n"
"                           winding (default): inside where the generalized\n"
"                           winding number w > 1/2 (Jacobson et al.), exactly:\n"
"                           open, cracked, mis-oriented and overlapping meshes\n"
"                           give what they enclose (the union of overlapping\n"
"                           parts, cavities kept), closed consistent meshes the\n"
"                           same voxels as parity. The mesh is prepared first:\n"
"                           vertices at equal positions merged, triangles\n"
"                           oriented across manifold edges (outwards; shells\n"
"                           nested in an odd number of others inwards), holes\n"
"                           closed by caps whose solid angle is taken off again.\n"
"                           winding-abs: |w| > 1/2 (keeps wholly inverted parts).\n"
"                           parity: an odd number of crossings beyond the centre\n"
"                           (Thon et al.; needs a closed mesh). The tetra method\n"
"                           is parity by construction.\n"
"  --weld EPS               winding: also merge vertices within EPS (mesh units)\n"
"                           of each other, closing cracks: the voxels are then\n"
"                           the welded mesh's (default 0: exact only). Without\n"
"                           it, cracks are the mesh's as given: a soup or a mesh\n"
"                           with many cracks is welded within 1/100 voxel only\n"
"                           to find its own exact voxels faster (\"cracks\" line)\n"
"\n", stdout);
    fputs(
"Method:\n"
"  --method ray|tetra       ray: quadtree + ray casting (Thon et al.); tetra: XOR\n"
"                           of the tetrahedra from one origin to every triangle\n"
"                           (Rueda et al.) (default ray)\n"
"  --axis x|y|z             ray direction (ray method; default x)\n"
"  --depth D                maximum quadtree depth (ray method; default 0 = auto)\n"
"  --leaf L                 split quadtree leaves holding more than L triangles\n"
"                           (ray method; default 0 = auto)\n"
"  --slab S                 slices per slab (default 0 = auto, memory-bounded)\n"
"  --tetra-origin centroid|bbox|x,y,z\n"
"                           common apex of the tetrahedra (tetra method; default\n"
"                           centroid: the area-weighted surface centroid; bbox:\n"
"                           the bounding box centre; or a point)\n"
"\n"
"Grey levels (coverage; Thon et al. 3.3.4; ray method only, not tetra):\n"
"  --oversample K           K x K rays per voxel column and K points per voxel\n"
"                           along each ray: coverage = points inside / K^3\n"
"  --oversample N,M         N x N rays per column, M points per voxel (the\n"
"                           paper's n rays x m points); N <= 16, M <= 255\n"
"                           Writes channel \"coverage\" (HALF in [0,1]) instead of\n"
"                           \"occupancy\". K = 1 gives exactly the binary volume.\n"
"                           Uniform: rays and points at the centres of N x N\n"
"                           sub-columns and M sub-segments.\n"
"  --stochastic             jitter each ray and point inside its stratum\n"
"                           (stratified; Philox4x32-10 keyed by the seed)\n"
"  --seed S                 seed of --stochastic (default 0): the same seed gives\n"
"                           the same volume on any device and slab size\n"
"  --threshold T            write \"occupancy\" = coverage > T (T in [0,1]) instead\n"
"                           of coverage: a binary volume that keeps details\n"
"                           thinner than a voxel at small T\n"
"  --channels LIST          channels to write, comma-separated: occupancy,\n"
"                           coverage (default: coverage when oversampled,\n"
"                           occupancy with --threshold or when binary); both:\n"
"                           --channels occupancy,coverage (T = 0.5 unless given)\n"
"  The paper's bytes 0-255 are round(255 * coverage).\n"
"\n"
"\n", stdout);
    fputs(
"Palette voxelization (Cavagnino & Gribaudo; ray method):\n"
"  --palette NAME|FILE      replace each voxel by the best-matching element of a\n"
"                           palette: binary, planar10, paper46, paper78 (clvox\n"
"                           palette list), or a palette file; writes the channels\n"
"                           \"element\" (UINT index, 0 = empty, 1 = full) and \"score\"\n"
"                           (HALF, the fraction of samples where element and\n"
"                           object agree)\n"
"  --metric nearest|outer|inner\n"
"                           nearest: most agreeing samples; outer: the same among\n"
"                           elements that hold every inside sample; inner: among\n"
"                           elements that hold no outside sample (default nearest)\n"
"  --samples T,P            T rays per voxel column (a square: an N x N grid) x P\n"
"                           points per voxel; at most 4096 samples (default 16,16;\n"
"                           --oversample N,M says the same as --samples N*N,M).\n"
"                           Uniform unless --stochastic (then --seed applies)\n"
"  --no-early-out           score every voxel, also those wholly inside or outside\n"
"                           (same result, slower; for measurements)\n"
"  --shortcut auto|A,B      nearest only: empty when fewer than A*T*P samples are\n"
"                           inside, full when more than B*T*P, unscored (auto: A =\n"
"                           smallest element volume / 10, B = 1 - (1 - largest)/10;\n"
"                           off by default: it can change elements)\n"
"  --channels also takes element and score; coverage and occupancy are those of\n"
"  the same samples (occupancy = coverage > --threshold, 0.5 by default).\n"
"\n"
"Output encoding:\n"
"  --compression none|rle|zip|zips|piz\n"
"                           EXR compression (default rle: fastest to write; zip\n"
"                           for palette runs, whose UINT element channel RLE\n"
"                           cannot shrink); .nrrd: none or zip (gzip, default)\n"
"  --threads N              host encoder threads (default 0 = number of cores)\n"
"\n", stdout);
    fputs(
"Device:\n"
"  --device SEL             auto, gpu, cpu, accelerator, an index from\n"
"                           --list-devices, or a case-insensitive substring of the\n"
"                           device or platform name (default: $CLVOX_DEVICE, else\n"
"                           auto = the first GPU, else the first CPU device);\n"
"                           several at once: SEL,SEL,... or all (every device):\n"
"                           the slabs are shared out by speed, the same voxels\n"
"                           (a device that fails is dropped with a warning)\n"
"  --list-devices           list the OpenCL devices (index, type, name, platform,\n"
"                           version, fp64, memory) and exit\n"
"  --float-kernels          build the kernels without double precision on every\n"
"                           device, as devices without fp64 always get them: the\n"
"                           same voxels in every mode. Without it a GPU whose\n"
"                           double measures 8x slower than its float (most\n"
"                           consumer cards) gets them (the summary's device line)\n"
"\n"
"Other:\n"
"  -q, --quiet              no summary and no progress bar (errors and warnings\n"
"                           still go to stderr)\n"
"  --no-progress            no progress bar (it is drawn on stderr only when\n"
"                           stderr is a terminal)\n"
"  --json                   instead of the summary, one JSON object on one line\n"
"                           on stdout: input, grid, method, mesh report, filled\n"
"                           voxels, volumes, seconds per stage, output, status\n"
"                           and error (docs/cli.md \"Machine-readable results\"); a\n"
"                           run that fails after its arguments were accepted\n"
"                           prints one too (status \"failed\"); errors and\n"
"                           warnings still go to stderr\n"
"  -h, --help               print this help and exit\n"
"  -V, --version            print the version and exit\n"
"  Ctrl-C (or SIGTERM, SIGHUP) cancels cleanly: no output file is left (exit\n"
"  130); a second Ctrl-C stops at once.\n"
"\n", stdout);
    fputs(
"A mesh must be closed for parity (inside) to mean anything; palette runs need\n"
"it too.\n"
"\n"
"clvox info FILE: prints the grid, method, parameters, compression and the\n"
"filled voxel count of a volume written by clvox (EXR, npy, NRRD, binvox or\n"
"vdb; occupancy > 0.5, or coverage > 0.5 without occupancy, or element != 0\n"
"without either); with a coverage\n"
"channel also the coverage sum and the estimated volume (sum x voxel volume);\n"
"with an element channel (palette runs) the palette, its hash and metric, and\n"
"the voxels of the most frequent elements, named when the palette can be\n"
"rebuilt from the header; --json: the same as one JSON object\n"
"(docs/cli.md \"Machine-readable results\"). Needs no OpenCL device.\n"
"\n"
"clvox batch: many meshes in one process, one OpenCL context and one kernel\n"
"build; output names from a template, --shard I/N, --skip-existing, a failed\n"
"mesh recorded and the batch going on (clvox batch --help).\n"
"\n"
"clvox preview FILE -o OUT.png: a shaded 3-D view, N evenly spaced z slices\n"
"and the three central slices of a volume (any format clvox writes) as a PNG\n"
"picture (clvox preview --help gives the exact layout). Needs no OpenCL device.\n"
"\n"
"clvox palette list | show NAME|FILE: the built-in palettes of sub-voxel\n"
"elements (binary, planar10, paper46, paper78), or the elements of one with\n"
"their volumes and symmetries (clvox palette --help). Needs no OpenCL device.\n"
"\n"
"clvox instances VOLUME.exr -o OUT.csv: one CSV row per non-empty voxel of a\n"
"palette volume (position, size, element, symmetry, score, render object from\n"
"--render-map), for scripts/tools/blender_instances.py (clvox instances --help).\n"
"\n"
"clvox mesh VOLUME -o OUT.{ply,obj,stl}: a volume's surface as a mesh: voxel\n"
"faces of occupancy (closed, outward), marching cubes of coverage (--smooth\n"
"for occupancy), or a palette volume's exact element shapes (PLY); streamed\n"
"slice by slice (clvox mesh --help). Needs no OpenCL device.\n"
"\n"
"After a run, one summary goes to stdout: mesh, grid, device, method, filled\n"
"voxels and volume, rays, time per stage and output size. A mesh that is not\n"
"closed (boundary edges) or has duplicated triangles (coincident surfaces,\n"
"which cancel under the parity rule) gets a warning on stderr, with either\n"
"method; so do rays with an odd number of crossings on a closed mesh.\n"
"\n"
"Exit codes:\n"
"  0    success\n"
"  1    runtime failure (OpenCL, kernel build, EXR, out of memory, internal)\n"
"  2    usage error (bad arguments)\n"
"  3    no OpenCL device\n"
"  4    input error: mesh (or the info/preview file) missing, unreadable, bad\n"
"       format, invalid (non-finite coordinates, bad indices) or empty\n"
"  5    output error: the output file can not be written\n"
"  6    grid error: zero or too large grid\n"
"  130  cancelled (SIGINT/SIGTERM/SIGHUP)\n"
"  Errors are one line on stderr: \"clvox: error: <message>\".\n"
"\n"
"Environment:\n"
"  CLVOX_DEVICE             device selector used when --device is not given\n"
"  CLVOX_DEFAULT_MESH       mesh used when no MESH is given (else\n"
"                           <exe dir>/../share/clvox/default.obj,\n"
"                           <exe dir>/../../tests/data/default.obj,\n"
"                           tests/data/default.obj, the first that exists)\n"
"  POCL_CACHE_DIR           must be a writable directory when the device is PoCL\n"
"                           (else PoCL reports no device at all)\n"
"  CLVOX_CACHE_DIR          where the compiled kernel program is kept between\n"
"                           runs (default $XDG_CACHE_HOME/clvox or\n"
"                           ~/.cache/clvox; off: build it in every run)\n"
"  CLVOX_VDB_PLUGIN         the OpenVDB writer plugin to load for .vdb output\n", stdout);
    fputs(
"\n"
"EXAMPLES (with no MESH, the bundled default mesh)\n"
"  clvox -r 128 -o solid.exr                solid: inside/outside, 128 voxels\n"
"                                           along the longest side\n"
"  clvox -r 128 --oversample 4 -o grey.exr  grey levels: coverage from 4x4 rays\n"
"                                           x 4 points per voxel\n"
"  clvox -r 64 --palette paper46 -o palette.exr\n"
"                                           palette: the best sub-voxel element\n"
"                                           of paper46 in each voxel\n"
"  clvox batch *.obj -r 64 -o '{stem}.exr'  batch: every mesh in one process\n"
"  clvox -r 128 -o solid.npy                format from the extension (npy, nrrd,\n"
"                                           binvox, vdb, exr); npy: + solid.json\n"
"  clvox convert solid.exr solid.nrrd       an EXR volume in another format\n"
"  clvox preview grey.exr -o grey.png       slices of a volume as a PNG\n", stdout);
}
