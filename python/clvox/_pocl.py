"""PoCL from PyPI (pip install "clvox[pocl]"): the pocl-binary-distribution wheel ships a
CPU OpenCL driver (libpocl) for machines without a system OpenCL ICD.

The ICD loader (ocl-icd) reads OCL_ICD_VENDORS when OpenCL is first used; pointing it at the
wheel's libpocl (an absolute library path) loads that driver alone, no LD_LIBRARY_PATH
needed (the wheel's libpocl finds its hwloc through its RPATH). This happens by itself at
`import clvox` when no system ICD is registered (/etc/OpenCL/vendors/*.icd) and neither
OCL_ICD_VENDORS nor OPENCL_VENDOR_PATH is set; CLVOX_POCL=1 forces it, CLVOX_POCL=0 turns it
off. It must happen before the first Context or clvox.devices() call of the process.

CPUs newer than the wheel's LLVM (PoCL 3.0 with LLVM 14.0.6, October 2022: e.g. AMD Zen 5,
CPUID family 26) are named "generic" by LLVM's host detection, and every kernel build then
fails with "unknown target CPU 'generic'" (PoCL issue 1049; PoCL has no setting for it and
rejects -mcpu build options). When that wheel's device says "generic", clvox gives it the
name of the code-generation target that matches the kernel library PoCL picked from the
CPU's features (see _target_for_features); CLVOX_POCL_CPU=NAME chooses another LLVM CPU
name, CLVOX_POCL_CPU=0 leaves the device alone. See _name_unknown_cpu for how."""
import ctypes
import glob
import os

POCL_CPU = None
"""The LLVM CPU name clvox gave the wheel's PoCL device, or None when it needed none."""

_keep = []  # the CPU name strings handed to PoCL live as long as the process


def _pocl_library():
    try:
        import pocl_binary_distribution as pbd  # noqa: F401
    except ImportError:
        return None
    site = os.path.dirname(os.path.dirname(os.path.abspath(pbd.__file__)))
    libs = sorted(glob.glob(os.path.join(site, "pyopencl", ".libs", "libpocl*.so*")))
    return libs[0] if libs else None


def _target_for_features(flags):
    """The CPU that PoCL's distro kernel library variants are tied to (the Debian mapping,
    PoCL pull request 1268), best first; PoCL 3.0 picks the variant by the same features."""
    for need, cpu in (("avx512f", "skylake-avx512"), ("avx2", "haswell"), ("fma4", "bdver1"),
                      ("f16c", "ivybridge"), ("avx", "sandybridge"), ("sse4_1", "penryn"),
                      ("ssse3", "core2")):
        if need in flags:
            return cpu
    return "x86-64"


def _cpu_flags():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def _mapped(perm):
    """A test "are bytes [a, a + n) mapped with this permission (r or w)" for this process."""
    spans = []
    with open("/proc/self/maps") as f:
        for line in f:
            addr, perms = line.split()[:2]
            if perm in perms[:2]:
                lo, hi = (int(x, 16) for x in addr.split("-"))
                spans.append((lo, hi))
    return lambda a, n: any(lo <= a and a + n <= hi for lo, hi in spans)


def _name_unknown_cpu():
    """Gives the wheel's PoCL 3.0 CPU device a CPU name LLVM knows, when it has "generic".

    PoCL keeps the name as a `char *llvm_cpu` in its device object (struct _cl_device_id,
    the cl_device_id itself) and passes it to clang and to the code generator at every
    kernel build. This finds that pointer: the first 8-byte field from the object's start
    (within 4 KiB) that points to the string "generic" (every address is checked against
    /proc/self/maps before it is read), and points it at a string of ours. The first, not
    the only one: the object is smaller than 4 KiB, and what the heap puts after it may
    hold another pointer to a "generic" (whether it does changed with the Python code
    that ran before, and with it every kernel build). Anything else (another PoCL, no such
    field) changes nothing, and builds fail as before. Returns the name given, or None."""
    choice = os.environ.get("CLVOX_POCL_CPU", "")
    if choice == "0":
        return None
    try:
        cl = ctypes.CDLL("libOpenCL.so.1")
    except OSError:
        return None
    vp, u32 = ctypes.c_void_p, ctypes.c_uint32
    n = u32()
    if cl.clGetPlatformIDs(0, None, ctypes.byref(n)) != 0 or n.value == 0:
        return None
    platforms = (vp * n.value)()
    if cl.clGetPlatformIDs(n.value, platforms, None) != 0:
        return None
    given = None
    for p in platforms:
        text = ctypes.create_string_buffer(512)
        if cl.clGetPlatformInfo(vp(p), 0x0901, 512, text, None) != 0:  # CL_PLATFORM_VERSION
            continue
        if b"PoCL 3.0" not in text.value:
            continue
        nd = u32()
        cpu_type = ctypes.c_uint64(1 << 1)  # CL_DEVICE_TYPE_CPU
        if cl.clGetDeviceIDs(vp(p), cpu_type, 0, None, ctypes.byref(nd)) != 0 or nd.value == 0:
            continue
        devs = (vp * nd.value)()
        if cl.clGetDeviceIDs(vp(p), cpu_type, nd.value, devs, None) != 0:
            continue
        ok, writable = _mapped("r"), _mapped("w")
        for d in devs:
            field = None
            for off in range(0, 4096, 8):
                if not ok(d + off, 8):
                    break
                v = ctypes.c_uint64.from_address(d + off).value
                if v and ok(v, 8) and ctypes.string_at(v, 8) == b"generic\0":
                    field = off
                    break
            if field is None or not writable(d + field, 8):
                continue
            name = choice or _target_for_features(_cpu_flags())
            buf = ctypes.create_string_buffer(name.encode())
            _keep.append(buf)
            ctypes.c_uint64.from_address(d + field).value = ctypes.addressof(buf)
            given = name
    return given


def use_pocl_binary_distribution(force=False):
    """Makes OpenCL use the pocl-binary-distribution wheel's PoCL. Without force, only when
    the process has no OpenCL driver of its own (see the module's doc). Returns the library
    path used, or None. Call it before the first Context; later calls change nothing."""
    global POCL_CPU
    if not force:
        if os.environ.get("OCL_ICD_VENDORS") or os.environ.get("OPENCL_VENDOR_PATH"):
            return None
        if glob.glob("/etc/OpenCL/vendors/*.icd"):
            return None
    path = _pocl_library()
    if path is None:
        return None
    os.environ["OCL_ICD_VENDORS"] = path
    try:
        POCL_CPU = _name_unknown_cpu()
    except (OSError, ValueError):  # no /proc (not Linux): PoCL keeps the name it has
        POCL_CPU = None
    return path


def _auto():
    flag = os.environ.get("CLVOX_POCL", "")
    if flag == "0":
        return None
    return use_pocl_binary_distribution(force=(flag == "1"))


POCL_LIBRARY = _auto()
