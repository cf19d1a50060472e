# SPDX-License-Identifier: Apache-2.0
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
fails with "unknown target CPU 'generic'" (PoCL issue 1049). PoCL 3.0 has no setting for the
name (no environment variable; it rejects -mcpu build options) and 3.0 is the wheel's latest
release. The device says so through the public API: its CL_DEVICE_VERSION ends in
"-generic" (PoCL's HSTR, "<driver>-<triple>-<cpu>"). Then, by default, nothing is changed
and POCL_ERROR says what to do; clvox.Context raises it (clvox.Error, kernel_build): install
the system's PoCL, or opt in with CLVOX_POCL_CPU=NAME, an LLVM CPU name, which clvox writes
into PoCL's device object (see _set_llvm_cpu: only inside that object, only the one field
that holds the CPU name). CLVOX_POCL_CPU=0 leaves the device alone without the error (the
builds fail with PoCL's own message)."""
import ctypes
import glob
import os

POCL_CPU = None
"""The LLVM CPU name clvox gave the wheel's PoCL device (CLVOX_POCL_CPU=NAME), or None."""

POCL_ERROR = None
"""Why the wheel's PoCL cannot build kernels in this process, or None; clvox.Context raises it."""

# sizeof(struct _cl_device_id) in the wheel's libpocl (PoCL 3.0-rc2, LLVM 14.0.6): the stride
# of its device array (clGetDeviceIDs with POCL_DEVICES="pthread pthread basic" gives devices
# 1024 bytes apart). The CPU name field (`char *llvm_cpu`, right after `char
# *llvm_target_triplet`) is at offset 640 there. Nothing past this size is read or written.
_DEVICE_SIZE = 1024


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


def _opencl_cpu_devices():
    """(cl_device_id, CL_DEVICE_VERSION) of every CPU device of the PoCL 3.0 platforms."""
    try:
        cl = ctypes.CDLL("libOpenCL.so.1")
    except OSError:
        return []
    vp, u32 = ctypes.c_void_p, ctypes.c_uint32
    n = u32()
    if cl.clGetPlatformIDs(0, None, ctypes.byref(n)) != 0 or n.value == 0:
        return []
    platforms = (vp * n.value)()
    if cl.clGetPlatformIDs(n.value, platforms, None) != 0:
        return []
    out = []
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
        for d in devs:
            version = ctypes.create_string_buffer(512)
            if d and cl.clGetDeviceInfo(vp(d), 0x102F, 512, version, None) == 0:  # CL_DEVICE_VERSION
                out.append((d, version.value.decode("ascii", "replace")))
    return out


def _set_llvm_cpu(device, version, name, size=_DEVICE_SIZE):
    """Points PoCL's `char *llvm_cpu` in the device object at `name` (opt-in only).

    The field is the one 8-byte field of the object's first `size` bytes that points to
    "generic" while the field before it points to the target triple that the device's HSTR
    (`version`, "...-<triple>-generic") names; with no such field, or more than one, nothing
    is written. Every address is checked against /proc/self/maps before it is read or
    written. The new name is a malloc'd copy (libc strdup), so that PoCL may free it; it lives
    as long as the process. Returns True when the field was changed."""
    hstr = version.rsplit(" ", 1)[-1]
    if not hstr.endswith("-generic"):
        return False
    head = hstr[:-len("-generic")]
    triples = [head[i + 1:].encode() for i, c in enumerate(head) if c == "-"]
    readable, writable = _mapped("r"), _mapped("w")
    if not readable(device, size):
        return False

    def points_to(off, text):
        v = ctypes.c_uint64.from_address(device + off).value
        return bool(v) and readable(v, len(text) + 1) and ctypes.string_at(v, len(text) + 1) == text + b"\0"

    fields = [off for off in range(8, size - 7, 8)
              if points_to(off, b"generic") and any(points_to(off - 8, t) for t in triples)]
    if len(fields) != 1 or not writable(device + fields[0], 8):
        return False
    libc = ctypes.CDLL(None)
    libc.strdup.restype = ctypes.c_void_p
    libc.strdup.argtypes = [ctypes.c_char_p]
    copy = libc.strdup(name.encode())
    if not copy:
        return False
    ctypes.c_uint64.from_address(device + fields[0]).value = copy
    return True


def _check_cpu_name():
    """(name given, error): see the module's doc. Changes PoCL's memory only with
    CLVOX_POCL_CPU=NAME."""
    choice = os.environ.get("CLVOX_POCL_CPU", "").strip()
    if choice == "0":
        return None, None
    generic = [(d, v) for d, v in _opencl_cpu_devices() if v.endswith("-generic")]
    if not generic:
        return None, None
    suggest = _target_for_features(_cpu_flags())
    if not choice:
        return None, ("the pocl-binary-distribution wheel's PoCL 3.0 (LLVM 14.0.6) does not know this CPU (it names "
                      "it 'generic'), so it cannot build clvox's kernels (PoCL issue 1049). Fixes: install the "
                      "system's PoCL (Debian/Ubuntu: apt install pocl-opencl-icd) or another OpenCL driver; or set "
                      f"CLVOX_POCL_CPU={suggest} (an LLVM CPU name; this one matches the kernel library PoCL picked "
                      "for this CPU's features) to have clvox write that name into PoCL's device object, a "
                      "workaround that changes PoCL's memory for every OpenCL user in this process")
    changed = [_set_llvm_cpu(d, v, choice) for d, v in generic]
    if not all(changed):
        return (choice if any(changed) else None), (
            f"CLVOX_POCL_CPU={choice}: the CPU name field was not found in the pocl-binary-distribution wheel's "
            "device object (not the PoCL 3.0 layout clvox knows), nothing was changed there; install the system's "
            "PoCL (Debian/Ubuntu: apt install pocl-opencl-icd) or another OpenCL driver")
    return choice, None


def use_pocl_binary_distribution(force=False):
    """Makes OpenCL use the pocl-binary-distribution wheel's PoCL. Without force, only when
    the process has no OpenCL driver of its own (see the module's doc). Returns the library
    path used, or None. Call it before the first Context; later calls change nothing."""
    global POCL_CPU, POCL_ERROR
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
        POCL_CPU, POCL_ERROR = _check_cpu_name()
    except (OSError, ValueError):  # no /proc (not Linux): PoCL keeps the name it has
        POCL_CPU, POCL_ERROR = None, None
    return path


def _auto():
    flag = os.environ.get("CLVOX_POCL", "")
    if flag == "0":
        return None
    return use_pocl_binary_distribution(force=(flag == "1"))


POCL_LIBRARY = _auto()
