/* SPDX-License-Identifier: Apache-2.0 */
/* The environment, read in one place (environment.h). */
#include "environment.h"

#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

const char *clvox__setting_value(clvox__setting s)
{
    static const char *const names[] = {
        [CLVOX__ENV_DEVICE] = "CLVOX_DEVICE",
        [CLVOX__ENV_CACHE_DIR] = "CLVOX_CACHE_DIR",
        [CLVOX__ENV_XDG_CACHE_HOME] = "XDG_CACHE_HOME",
        [CLVOX__ENV_HOME] = "HOME",
        [CLVOX__ENV_VDB_PLUGIN] = "CLVOX_VDB_PLUGIN",
    };
    if ((unsigned)s >= sizeof names / sizeof names[0]) return NULL;
    return getenv(names[s]);
}

static int is(const char *name, const char *value)
{
    const char *e = getenv(name);
    return e && strcmp(e, value) == 0;
}

/* An integer in [lo, hi], else 0. */
static long in_range(const char *name, long lo, long hi)
{
    const char *e = getenv(name);
    if (!e || !*e) return 0;
    char *end;
    long v = strtol(e, &end, 10);
    return *end == 0 && v >= lo && v <= hi ? v : 0;
}

static clvox__test_hooks from_environment(void)
{
    clvox__test_hooks h = {0};
    h.kernels_float = is("CLVOX_KERNEL_FLOAT", "1");
    const char *kfd = getenv("CLVOX_KERNEL_FLOAT_DEVICE");
    h.kernels_float_device = kfd && *kfd >= '0' && *kfd <= '9' ? atoi(kfd) + 1 : 0;
    h.mesh_reader_openmesh = is("CLVOX_MESH_READER", "openmesh");
    h.palette_no_masks = is("CLVOX_BENCH_NO_MASKS", "1");
    h.partition_lean_bits = (unsigned)in_range("CLVOX_PARTITION_LEAN_BITS", 10, 24);
    const char *apex = getenv("CLVOX_CAP_APEX");
    if (apex) {
        char *end;
        double f = strtod(apex, &end);
        if (end != apex && isfinite(f)) h.cap_apex_set = 1, h.cap_apex = f;
    }
    h.host_threads = (int)in_range("CLVOX_HOST_THREADS", 1, 1 << 20);
    h.fail_device_k = -1;
    const char *fail = getenv("CLVOX_TEST_FAIL_DEVICE");
    if (fail && *fail) {
        char *colon = (char *)fail + 1, *end;
        long k = fail[0] == '*' ? CLVOX__FAIL_EVERY_DEVICE : strtol(fail, &colon, 10);
        if (*colon == ':' && (k == CLVOX__FAIL_EVERY_DEVICE || (k >= 0 && k < 64))) {
            unsigned long n = strtoul(colon + 1, &end, 10);
            if (!strcmp(colon + 1, "prepare"))
                h.fail_device_k = (int)k, h.fail_device_n = CLVOX__FAIL_PREPARE;
            else if (end != colon + 1 && *end == 0 && n < (1ul << 30))
                h.fail_device_k = (int)k, h.fail_device_n = n ? (unsigned)n : CLVOX__FAIL_BUILD;
        }
    }
    h.device_max_alloc = (unsigned long long)in_range("CLVOX_DEVICE_MAX_ALLOC", 1, LONG_MAX);
    h.device_global_mem = (unsigned long long)in_range("CLVOX_DEVICE_GLOBAL_MEM", 1, LONG_MAX);
    h.local_size = (unsigned)in_range("CLVOX_LOCAL_SIZE", 1, 1024);
    h.launch_slabs = (unsigned)in_range("CLVOX_LAUNCH_SLABS", 1, 4096);
    h.host_rays = is("CLVOX_HOST_RAYS", "1");
    h.batch_items = (unsigned)in_range("CLVOX_BATCH_ITEMS", 1, 1 << 30);
    h.copy_slabs = is("CLVOX_COPY_SLABS", "1");
    h.fp32_unrounded = is("CLVOX_TEST_FP32_UNROUNDED", "1");
    h.no_crack_weld = is("CLVOX_CRACK_WELD", "0");
    h.lattice = is("CLVOX_WINDING_LATTICE", "0") ? -1 : is("CLVOX_WINDING_LATTICE", "1") ? 1 : 0;
    h.unsure_room = (unsigned)in_range("CLVOX_UNSURE_ROOM", 1, 4096);
    const char *slow = getenv("CLVOX_FP64_SLOWDOWN");
    if (slow && *slow) {
        char *end;
        double r = strtod(slow, &end);
        if (*end == 0 && r >= 1.0 && r <= 1024.0) h.fp64_slowdown = r;
    }
    h.fp64_measure = is("CLVOX_FP64_MEASURE", "1");
    const char *crash = getenv("CLVOX_TEST_ASSIMP_CRASH");
    if (crash && *crash && strlen(crash) < sizeof h.assimp_crash) strcpy(h.assimp_crash, crash);
    return h;
}

static clvox__test_hooks g_hooks;
static pthread_once_t g_once = PTHREAD_ONCE_INIT;

static void read_once(void)
{
    g_hooks = from_environment();
}

const clvox__test_hooks *clvox__hooks(void)
{
    pthread_once(&g_once, read_once);
    return &g_hooks;
}

void clvox__set_test_hooks(const clvox__test_hooks *hooks)
{
    pthread_once(&g_once, read_once);
    g_hooks = hooks ? *hooks : from_environment();
}

int clvox__hook_fails_device(unsigned position, unsigned n)
{
    const clvox__test_hooks *h = clvox__hooks();
    return n && h->fail_device_n == n &&
           (h->fail_device_k == (int)position || h->fail_device_k == CLVOX__FAIL_EVERY_DEVICE);
}
