/* SPDX-License-Identifier: Apache-2.0 */
/* The one place the library reads the environment (environment.c): the
 * user's settings, read when they are used, and the switches for tests and
 * benchmarks, read once into one struct that tests may also set directly.
 * No other library file calls getenv. Internal. */
#ifndef CLVOX_ENVIRONMENT_H
#define CLVOX_ENVIRONMENT_H

/* User settings (documented in docs/cli.md): read on every use, so that a
 * program may change them between calls. */
typedef enum clvox__setting {
    CLVOX__ENV_DEVICE,         /* CLVOX_DEVICE: the default device selector */
    CLVOX__ENV_CACHE_DIR,      /* CLVOX_CACHE_DIR: the kernel cache ("off": none) */
    CLVOX__ENV_XDG_CACHE_HOME, /* XDG_CACHE_HOME: the cache's parent when the above is unset */
    CLVOX__ENV_HOME,           /* HOME: ~/.cache otherwise */
    CLVOX__ENV_VDB_PLUGIN      /* CLVOX_VDB_PLUGIN: the .vdb writer module to load */
} clvox__setting;

/* The setting's value, or NULL when unset. */
const char *clvox__setting_value(clvox__setting s);

/* Switches for tests and benchmarks, not user settings. Each changes how a
 * result is computed, never the result (the tests check that), except
 * kernels_float, which builds the kernels as for a device without fp64. */
typedef struct clvox__test_hooks {
    int kernels_float;         /* CLVOX_KERNEL_FLOAT=1: kernels built with -DCLVOX_NO_FP64 */
    int kernels_float_device;  /* CLVOX_KERNEL_FLOAT_DEVICE=K: K + 1; only device K of a set (its position
                                * in the device list, from 0) built so, as a device without fp64 beside
                                * ones with it; 0: none (a zeroed struct builds none so) */
    int mesh_reader_openmesh;  /* CLVOX_MESH_READER=openmesh: binary PLY/STL through OpenMesh */
    int palette_no_masks;      /* CLVOX_BENCH_NO_MASKS=1: uniform palette samples scored one by one */
    unsigned partition_lean_bits; /* CLVOX_PARTITION_LEAN_BITS=10..24: 2^bits triangles start the
                                   * quadtree's memory-lean paths; 0: the default (20) */
    int cap_apex_set;          /* CLVOX_CAP_APEX=F: the winding caps' apex offset (else 0.0731) */
    double cap_apex;
    int host_threads;          /* CLVOX_HOST_THREADS=1..16: host threads; 0: the online cores, at most 8 */
    /* CLVOX_TEST_FAIL_DEVICE=K:N: device K of a run's device list (from 0)
     * fails at its N-th slab (from 1) with an OpenCL error; N = 0 fails its
     * kernel build at context creation (fail_device_n = CLVOX__FAIL_BUILD),
     * N = "prepare" its preparation of a run, once its methods are prepared
     * (fail_device_n = CLVOX__FAIL_PREPARE).
     * K = '*' (CLVOX__FAIL_EVERY_DEVICE):
     * every device does. fail_device_k = -1: off. */
    int fail_device_k;
    unsigned fail_device_n;
    /* CLVOX_DEVICE_MAX_ALLOC=bytes, CLVOX_DEVICE_GLOBAL_MEM=bytes: the device's largest buffer and
     * global memory believed lower than reported (0: as reported); batches shrink to fit, or the run
     * fails with CLVOX_ERR_OUT_OF_MEMORY where one voxel column does not fit */
    unsigned long long device_max_alloc, device_global_mem;
    unsigned local_size;       /* CLVOX_LOCAL_SIZE=1..1024: the kernels' work-groups at most this large
                                * (launch.c); 0: the device's and kernels' limits only */
    unsigned launch_slabs;     /* CLVOX_LAUNCH_SLABS=1..4096: slabs each device computes per method call
                                * (voxelize.c, schedule.c; 0: sized to the device) */
    int host_rays;             /* CLVOX_HOST_RAYS=1: column runs' ray positions made on the host even where
                                * the device could make them (cast.c; the outputs are the same) */
    unsigned batch_items;      /* CLVOX_BATCH_ITEMS=1..2^30: the ray method's batches at most this many items
                                * (rays, or columns of N*N rays; cast.c): many batches a slab. 0: off */
    int copy_slabs;            /* CLVOX_COPY_SLABS=1: one CPU device's slabs copied into the writer's slots
                                * rather than handed over mapped (schedule.c; the outputs are the same) */
    int fp32_unrounded;        /* CLVOX_TEST_FP32_UNROUNDED=1: built as for a device without correctly
                                * rounded float divide/sqrt (no -cl-fp32-correctly-rounded-divide-sqrt) */
    int no_crack_weld;         /* CLVOX_CRACK_WELD=0: no certified crack weld (src/winding/crack_weld.c; the
                                * voxels are the same, found the slow way) */
    int lattice;               /* CLVOX_WINDING_LATTICE=0 (-1): no block lattice near the caps
                                * (kernels/winding_lattice.h; the same voxels, found voxel by voxel); =1 (1):
                                * one on grids of any size (S from 4), not only from 192 voxels on */
    unsigned unsure_room;      /* CLVOX_UNSURE_ROOM=1..4096: a float device's unsure winding points a batch
                                * lists before its consumer runs again with room for all
                                * (src/cast/unsure.c; the outputs are the same). 0: 4096 */
    double fp64_slowdown;      /* CLVOX_FP64_SLOWDOWN=R (1 to 1024): every device with fp64 taken to run
                                * double R times slower than float, not measured (device_speed.c); the
                                * rule then picks the build. 0: measured on GPUs, CPUs keep double */
    int fp64_measure;          /* CLVOX_FP64_MEASURE=1: CPU devices measured too (device_speed.c) */
    char assimp_crash[64];     /* CLVOX_TEST_ASSIMP_CRASH=TEXT: the Assimp reader kills its process
                                * (SIGSEGV) on a file whose path contains TEXT, a stand-in for a
                                * parser bug (test_assimp: load and batch) */
} clvox__test_hooks;
#define CLVOX__FAIL_EVERY_DEVICE (-2)
/* fail_device_n of "K:0" (the build): a zero-initialised struct fails nothing
 * (no device has a slab 0). */
#define CLVOX__FAIL_BUILD 0xFFFFFFFFu
/* fail_device_n of "K:prepare" (voxelize.c, after the device's prepare). */
#define CLVOX__FAIL_PREPARE 0xFFFFFFFEu

/* Whether CLVOX_TEST_FAIL_DEVICE says device `position` fails at its n-th
 * slab (from 1; n = CLVOX__FAIL_BUILD: its kernel build; n =
 * CLVOX__FAIL_PREPARE: its preparation of a run). */
int clvox__hook_fails_device(unsigned position, unsigned n);

/* The switches in force: the environment's, read once on the first call,
 * unless a test has set them. */
const clvox__test_hooks *clvox__hooks(void);

/* Sets the switches (a test, before the runs it affects: not while another
 * thread runs the library); NULL goes back to the environment's. */
void clvox__set_test_hooks(const clvox__test_hooks *hooks);
#endif
