# SPDX-License-Identifier: Apache-2.0
"""The pocl-binary-distribution fallback on a CPU its LLVM does not know (simulated: a fake
OpenCL whose PoCL 3.0 device names the CPU "generic", and a fake device object in our own
memory). By default nothing is written and Context() raises an error that names the
fixes; CLVOX_POCL_CPU=NAME changes only the CPU name field inside the device object
(issue 32, defect 8)."""
import ctypes

import pytest

import clvox
import clvox._pocl as pocl

TRIPLE = b"x86_64-unknown-linux-gnu"
SIZE = 1024  # the wheel's struct _cl_device_id
VERSION = b"OpenCL 3.0 PoCL HSTR: pthread-" + TRIPLE + b"-generic"


class FakeOpenCL:
    """One PoCL 3.0 platform with one CPU device, whose cl_device_id is `device`."""

    def __init__(self, device, version=VERSION):
        self.device, self.version = device, version

    def clGetPlatformIDs(self, num, platforms, count):
        if count is not None:
            count._obj.value = 1
        if platforms is not None:
            platforms[0] = 0x1000
        return 0

    def clGetPlatformInfo(self, platform, param, size, value, ret):
        value.value = b"OpenCL 3.0 PoCL 3.0-rc2  Linux, Release, RELOC, LLVM 14.0.6, SLEEF, DISTRO"
        return 0

    def clGetDeviceIDs(self, platform, kind, num, devices, count):
        if count is not None:
            count._obj.value = 1
        if devices is not None:
            devices[0] = self.device
        return 0

    def clGetDeviceInfo(self, device, param, size, value, ret):
        assert param == 0x102F  # CL_DEVICE_VERSION
        value.value = self.version
        return 0


class Object:
    """A fake device object: SIZE bytes and a tail past its end, pointer fields set by offset."""

    def __init__(self, fields, total=2 * SIZE):
        self.mem = ctypes.create_string_buffer(total)
        self.strings = []
        for off, text in fields.items():
            s = ctypes.create_string_buffer(text)
            self.strings.append(s)
            ctypes.c_uint64.from_buffer(self.mem, off).value = ctypes.addressof(s)
        self.before = self.mem.raw

    @property
    def address(self):
        return ctypes.addressof(self.mem)

    def field(self, off):
        return ctypes.string_at(ctypes.c_uint64.from_buffer(self.mem, off).value)

    def changed(self):
        return [i for i in range(0, len(self.before), 8) if self.mem.raw[i:i + 8] != self.before[i:i + 8]]


@pytest.fixture
def fallback(monkeypatch):
    """Runs use_pocl_binary_distribution(force=True) against a fake OpenCL; restores the
    module's globals and the environment."""
    real = ctypes.CDLL
    for name in ("POCL_LIBRARY", "POCL_CPU", "POCL_ERROR"):
        monkeypatch.setattr(pocl, name, getattr(pocl, name, None), raising=False)
    monkeypatch.setenv("OCL_ICD_VENDORS", "unchanged")
    monkeypatch.delenv("CLVOX_POCL_CPU", raising=False)
    monkeypatch.setattr(pocl, "_pocl_library", lambda: "/nonexistent/libpocl-fake.so")

    def run(obj, version=VERSION, cpu=None):
        if cpu is not None:
            monkeypatch.setenv("CLVOX_POCL_CPU", cpu)
        fake = FakeOpenCL(obj.address, version)
        monkeypatch.setattr(ctypes, "CDLL", lambda name, *a, **k: fake if name == "libOpenCL.so.1" else real(name))
        try:
            assert pocl.use_pocl_binary_distribution(force=True) == "/nonexistent/libpocl-fake.so"
        finally:
            monkeypatch.setattr(ctypes, "CDLL", real)
        return pocl.POCL_CPU, getattr(pocl, "POCL_ERROR", None)
    return run


def test_default_writes_nothing_and_names_the_fixes(fallback):
    obj = Object({632: TRIPLE, 640: b"generic"})
    cpu, err = fallback(obj)
    assert obj.changed() == [] and cpu is None
    assert err and "apt install pocl-opencl-icd" in err and "CLVOX_POCL_CPU=" in err and "generic" in err
    with pytest.raises(clvox.Error) as e:
        clvox.Context()
    assert "CLVOX_POCL_CPU=" in str(e.value) and e.value.status_name == "kernel_build"
    clvox.Context(host_only=True)  # reading volumes needs no kernels


def test_opt_in_changes_only_the_name_field(fallback):
    obj = Object({632: TRIPLE, 640: b"generic", 1200: b"generic"})
    cpu, err = fallback(obj, cpu="haswell")
    assert cpu == "haswell" and err is None
    assert obj.changed() == [640] and obj.field(640) == b"haswell"


def test_opt_in_stays_inside_the_object(fallback):
    # "generic" fields only past the object's end (unrelated heap): nothing is written
    obj = Object({SIZE + 56: TRIPLE, SIZE + 64: b"generic", SIZE + 200: b"generic"})
    cpu, err = fallback(obj, cpu="haswell")
    assert obj.changed() == [] and cpu is None
    assert err and "nothing was changed" in err


def test_opt_in_needs_one_unambiguous_field(fallback):
    # a "generic" not after the triple, or two candidates: nothing is written
    for fields in ({640: b"generic"}, {632: TRIPLE, 640: b"generic", 712: TRIPLE, 720: b"generic"}):
        obj = Object(fields)
        cpu, err = fallback(obj, cpu="haswell")
        assert obj.changed() == [] and cpu is None and err


def test_known_cpu_is_left_alone(fallback):
    obj = Object({632: TRIPLE, 640: b"znver3"})
    cpu, err = fallback(obj, version=VERSION.replace(b"generic", b"znver3"))
    assert obj.changed() == [] and cpu is None and err is None
    cpu, err = fallback(obj, version=VERSION.replace(b"generic", b"znver3"), cpu="haswell")
    assert obj.changed() == [] and cpu is None and err is None
