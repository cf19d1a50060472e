"""PoCL from PyPI (pip install "clvox[pocl]"): the pocl-binary-distribution wheel ships a
CPU OpenCL driver (libpocl) for machines without a system OpenCL ICD.

The ICD loader (ocl-icd) reads OCL_ICD_VENDORS when OpenCL is first used; pointing it at the
wheel's libpocl (an absolute library path) loads that driver alone, no LD_LIBRARY_PATH
needed (the wheel's libpocl finds its hwloc through its RPATH). This happens by itself at
`import clvox` when no system ICD is registered (/etc/OpenCL/vendors/*.icd) and neither
OCL_ICD_VENDORS nor OPENCL_VENDOR_PATH is set; CLVOX_POCL=1 forces it, CLVOX_POCL=0 turns it
off. It must happen before the first Context or clvox.devices() call of the process."""
import glob
import os


def _pocl_library():
    try:
        import pocl_binary_distribution as pbd  # noqa: F401
    except ImportError:
        return None
    site = os.path.dirname(os.path.dirname(os.path.abspath(pbd.__file__)))
    libs = sorted(glob.glob(os.path.join(site, "pyopencl", ".libs", "libpocl*.so*")))
    return libs[0] if libs else None


def use_pocl_binary_distribution(force=False):
    """Makes OpenCL use the pocl-binary-distribution wheel's PoCL. Without force, only when
    the process has no OpenCL driver of its own (see the module's doc). Returns the library
    path used, or None. Call it before the first Context; later calls change nothing."""
    if not force:
        if os.environ.get("OCL_ICD_VENDORS") or os.environ.get("OPENCL_VENDOR_PATH"):
            return None
        if glob.glob("/etc/OpenCL/vendors/*.icd"):
            return None
    path = _pocl_library()
    if path is None:
        return None
    os.environ["OCL_ICD_VENDORS"] = path
    return path


def _auto():
    flag = os.environ.get("CLVOX_POCL", "")
    if flag == "0":
        return None
    return use_pocl_binary_distribution(force=(flag == "1"))


POCL_LIBRARY = _auto()
