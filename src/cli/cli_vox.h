/* SPDX-License-Identifier: Apache-2.0 */
/* The voxelization run of the command line, shared by `clvox MESH` (cli.c)
 * and `clvox batch` (cli_batch.c): arguments, a session (contexts, palette
 * and --like grid opened once) and one mesh's run with its result. */
#ifndef CLVOX_CLI_VOX_H
#define CLVOX_CLI_VOX_H

#include "clvox.h"
#include "cli_json.h"

#include <stddef.h>
#include <stdint.h>

enum { GRID_BY_RESOLUTION = 1, GRID_BY_DIMS = 2, GRID_BY_VOXEL_SIZE = 4 };

/* -r when no grid option is given (vox_run; said in --help). */
#define DEFAULT_RESOLUTION 256u

typedef struct cli_args {
    const char *mesh;
    const char *output;        /* batch: the output template */
    clvox_grid_options grid;
    int grid_by;        /* GRID_BY_* bits */
    const char *grid_opt[3];
    clvox_voxelize_options vox;
    const char *device;
    int float_kernels;        /* --float-kernels: clvox_context_options.float_kernels */
    int list_devices, quiet, no_progress, help, version;
    int seed_given;
    const char *palette;       /* --palette NAME|FILE */
    const char *samples_opt;   /* "--samples" or "--oversample", whichever set them */
    int metric_given;
    clvox_output_options out;  /* --format, --npy-bits, --npy-float32, --npy-uint32 */
    int json;                  /* --json: one JSON object per mesh on stdout */
    const char *like;          /* --like FILE: the grid of an existing volume */
    int pad_given;
    /* batch (parse_args with multi = 1): every MESH argument, in order */
    const char **meshes;
    size_t mesh_count;
} cli_args;

/* Options parse_args does not know: returns 1 when argv[*i] was consumed
 * (advancing *i past a value), 0 when it is not an option of the caller, or
 * -1 after reporting a usage error. */
typedef int (*cli_extra_opt_fn)(void *user, int argc, char **argv, int *i);

/* argv[first..argc-1]. multi: MESH arguments go to a->meshes (free it).
 * Returns EXIT_OK or the exit code of the reported error. */
int parse_args(int argc, char **argv, int first, int multi, cli_extra_opt_fn extra, void *user, cli_args *a);
/* Same grid-kind rules as the command line (-r/--dims/--voxel-size, one of
 * them), for per-mesh overrides; `what` prefixes the message. */
const char *grid_option_parse(const char *opt, const char *value, clvox_grid_options *g, int *grid_by);

/* What one run needs that can be opened once for many meshes. */
typedef struct vox_session {
    const cli_args *a;
    clvox_context *host;       /* meshes, grids, --like */
    clvox_context *dev;        /* opened at the first voxelization */
    clvox_palette *palette;
    int have_like;
    clvox_grid like;           /* --like FILE */
    double setup_seconds;      /* the device context's creation (paid once) */
    int batch;                 /* messages name the mesh; no progress bar */
} vox_session;

/* Host context, palette, --like grid, signal handlers. EXIT_OK or the
 * reported error's code; vox_session_close in every case. */
int vox_session_open(vox_session *s, const cli_args *a);
void vox_session_close(vox_session *s);

#define VOX_MAX_WARNINGS 8

/* One mesh's job and result. */
typedef struct vox_job {
    const char *mesh;
    const char *output;
    int grid_by;                /* 0: the session's grid options */
    clvox_grid_options grid;    /* used when grid_by != 0 */
    int64_t n;                  /* position in the batch list, -1 for a single run */
    const char *source;         /* "MANIFEST:LINE" or NULL */
    unsigned line;              /* manifest line, 0 if none */
    /* A mesh loaded ahead (batch, cli_batch.c): with `preloaded` vox_run
     * takes mesh_ahead (and destroys it in every case) instead of loading
     * the mesh, or where that load failed (mesh_ahead NULL) reports
     * mesh_status with mesh_ctx's message. */
    int preloaded;
    clvox_mesh *mesh_ahead;
    clvox_status mesh_status;
    clvox_context *mesh_ctx;
    double mesh_seconds;
    int make_dirs;              /* batch: create the output's missing directories */
} vox_job;

typedef struct vox_result {
    const char *status;         /* "ok", "failed", "skipped", "cancelled" */
    int fatal;                  /* 1: the rest of a batch can not succeed (no device, cancelled) */
    int rc;                     /* exit code of this mesh */
    char error[1024];           /* the one-line message when failed */
    int have_report, have_grid, have_stats;
    clvox_mesh_report report;
    clvox_mesh_source_info source; /* .reader "assimp": a scene (a "scene" line and JSON object) */
    clvox_grid grid;
    clvox_stats stats;
    double load_seconds, setup_seconds, wall_seconds;
    uint64_t output_size;
    int warning_count;
    char warnings[VOX_MAX_WARNINGS][512];
} vox_result;

/* Loads, grids and voxelizes one mesh. Errors are reported (one line on
 * stderr, prefixed with job->source or the mesh in a batch) and recorded in
 * res; returns res->rc. Warnings are recorded, not printed. */
int vox_run(vox_session *s, const vox_job *job, vox_result *res);
/* Prints the recorded warnings, one "clvox: warning:" line each. */
void vox_print_warnings(const vox_session *s, const vox_job *job, const vox_result *res);
/* The JSON object of one mesh (docs/cli.md "Machine-readable results"). */
void vox_result_json(const vox_session *s, const vox_job *job, const vox_result *res, jbuf *b);

/* The text summary of one run that succeeded (`clvox MESH`, cli.c). */
void print_summary(const char *mesh_path, const clvox_mesh_report *r, const clvox_mesh_source_info *src,
                   const clvox_grid *grid,
                   const clvox_context *devices, const cli_args *a, const clvox_palette *pal,
                   const clvox_stats *s, const char *output, double setup_seconds, double wall_seconds);

/* 1 once SIGINT/SIGTERM/SIGHUP arrived. */
int cli_interrupted(void);
double cli_now(void);

#endif
