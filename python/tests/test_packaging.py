"""pip wheel ./python works; the pocl extra's PoCL gives the same voxels."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import DEFAULT, REPO

CHILD = r"""
import json, sys, numpy as np, clvox
ctx = clvox.Context()
v = ctx.voxelize(sys.argv[1], resolution=40, oversample=2)
print(json.dumps({"file": clvox.__file__, "device": ctx.device["name"], "pocl": clvox._pocl.POCL_LIBRARY,
                  "sum": float(v.coverage.astype(np.float64).sum()), "hash": hash(v.coverage.tobytes())}))
"""


def child(env, path, code=CHILD):
    p = subprocess.run([sys.executable, "-c", code, DEFAULT], capture_output=True, text=True, env=env,
                       cwd=path)
    if "unknown target CPU 'generic'" in p.stderr:
        # PoCL 3.0's LLVM does not know this CPU (pocl issue 1049): the wheel's device is found
        # but can not build kernels here. Newer CPUs need a newer PoCL wheel.
        pytest.xfail("the wheel's PoCL can not compile for this CPU: unknown target CPU 'generic'")
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout.strip().splitlines()[-1])


def test_pip_wheel_and_install(tmp):
    pytest.importorskip("pip")
    env = dict(os.environ, PIP_DISABLE_PIP_VERSION_CHECK="1", PYTHONHASHSEED="0")
    p = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-build-isolation", "--no-deps", "-q", "-w",
                        str(tmp / "wheels"), os.path.join(REPO, "python")], capture_output=True, text=True, env=env)
    assert p.returncode == 0, p.stderr
    wheels = os.listdir(tmp / "wheels")
    assert len(wheels) == 1 and wheels[0].startswith("clvox-0.1.0-") and wheels[0].endswith(".whl")
    p = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(tmp / "site"),
                        str(tmp / "wheels" / wheels[0])], capture_output=True, text=True, env=env)
    assert p.returncode == 0, p.stderr
    got = child(dict(env, PYTHONPATH=str(tmp / "site")), str(tmp))
    assert got["file"].startswith(str(tmp / "site"))
    ref = child(env, str(tmp))  # the in-tree build this suite runs on
    assert ref["file"] != got["file"] and ref["hash"] == got["hash"]


def test_pocl_binary_distribution(tmp):
    pytest.importorskip("pocl_binary_distribution")
    env = dict(os.environ, PYTHONHASHSEED="0")
    ref = child(env, str(tmp))
    env.pop("OCL_ICD_VENDORS", None)
    env["CLVOX_POCL"] = "1"
    env["POCL_CACHE_DIR"] = str(tmp / "pocl-cache")
    listed = subprocess.run([sys.executable, "-c", "import clvox; print(clvox._pocl.POCL_LIBRARY); "
                             "print(clvox.devices())"], capture_output=True, text=True, env=env, cwd=str(tmp))
    assert listed.returncode == 0 and "pyopencl" in listed.stdout and "Portable Computing Language" in listed.stdout
    got = child(env, str(tmp))
    assert got["pocl"] and "pyopencl" in got["pocl"]
    assert got["hash"] == ref["hash"] and got["sum"] == ref["sum"]
    print("system:", ref["device"], "| wheel:", got["device"])
