#include "test.h"
#include <sys/stat.h>

int test_passed, test_failed;

int test_report(void)
{
    printf("%d passed, %d failed\n", test_passed, test_failed);
    return test_failed ? 1 : 0;
}

clvox_context *test_context(void)
{
    clvox_context *ctx = NULL;
    clvox_context_options o = CLVOX_CONTEXT_OPTIONS_INIT;
    clvox_status st = clvox_context_create(&o, &ctx);
    if (st != CLVOX_OK) {
        fprintf(stderr, "cannot create an OpenCL context: %s: %s\n", clvox_status_string(st),
                clvox_context_error(ctx));
        clvox_context_destroy(ctx);
        printf("0 passed, 1 failed\n");
        exit(1);
    }
    return ctx;
}

const char *test_tmpdir(void)
{
    const char *d = getenv("CLVOX_TEST_TMP");
    if (!d || !*d) d = "build/test-tmp";
    mkdir("build", 0777);
    mkdir(d, 0777);
    return d;
}
