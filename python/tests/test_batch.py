# SPDX-License-Identifier: Apache-2.0
"""clvox.batch: the files `clvox batch` writes, byte for byte, with the same sharding,
template and resume rules."""
import os
import subprocess

import pytest

import clvox
from conftest import DEFAULT, mesh_path

NAMES = ["cow.off", "bunny00.off", "cube-ouvert.off", "cross.off", "elephant-with-holes.off"]


def _meshes():
    return [DEFAULT] + [mesh_path(n) for n in NAMES]


def _bytes(path):
    with open(path, "rb") as f:
        return f.read()


def test_equals_cli_batch(ctx, cli, tmp):
    meshes = _meshes()
    (tmp / "cli").mkdir()
    p = subprocess.run([os.environ.get("CLVOX_BIN", "clvox"), "batch", *meshes, "-r", "24", "-q",
                        "-o", str(tmp / "cli" / "{n}_{stem}.exr")], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    res = ctx.batch(meshes, str(tmp / "py" / "sub" / "{n}_{stem}.exr"), resolution=24)
    assert [r["status"] for r in res] == ["ok"] * len(meshes)
    assert [r["n"] for r in res] == list(range(len(meshes)))
    for k, m in enumerate(meshes):
        stem = os.path.basename(m).rsplit(".", 1)[0]
        a, b = tmp / "cli" / f"{k}_{stem}.exr", tmp / "py" / "sub" / f"{k}_{stem}.exr"
        assert res[k]["output"] == str(b)
        assert _bytes(a) == _bytes(b), m


def test_shards_partition_the_list(ctx, tmp):
    meshes = _meshes()
    whole = {r["n"]: _bytes(r["output"]) for r in ctx.batch(meshes, str(tmp / "all" / "{n}.npy"), resolution=16)}
    seen = []
    for i in range(3):
        res = clvox.batch(meshes, str(tmp / "sh" / "{n}.npy"), shard=(i, 3), resolution=16)
        assert all(r["n"] % 3 == i and r["status"] == "ok" for r in res)
        seen += [r["n"] for r in res]
    assert sorted(seen) == list(range(len(meshes)))
    for k in range(len(meshes)):
        assert _bytes(tmp / "sh" / f"{k}.npy") == whole[k]


def test_skip_existing_resumes(ctx, tmp):
    meshes = _meshes()
    first = ctx.batch(meshes[:2], str(tmp / "{n}.exr"), resolution=16)
    assert [r["status"] for r in first] == ["ok", "ok"]
    before = _bytes(tmp / "0.exr")
    again = ctx.batch(meshes, str(tmp / "{n}.exr"), skip_existing=True, resolution=16)
    assert [r["status"] for r in again] == ["skipped", "skipped"] + ["ok"] * (len(meshes) - 2)
    assert _bytes(tmp / "0.exr") == before


def test_a_failing_mesh_does_not_stop_the_others(ctx, tmp):
    bad = tmp / "bad.off"
    bad.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")  # index 7: no such vertex
    res = ctx.batch([str(bad), DEFAULT], str(tmp / "o" / "{stem}.exr"), resolution=16)
    assert res[0]["status"] == "failed" and res[0]["error"] and not os.path.exists(res[0]["output"])
    assert res[1]["status"] == "ok" and os.path.exists(res[1]["output"])


@pytest.mark.parametrize("template", ["{stem", "x}.exr", "{nope}.exr"])
def test_bad_template(ctx, tmp, template):
    with pytest.raises(ValueError):
        ctx.batch([DEFAULT], str(tmp / template), resolution=8)


@pytest.mark.parametrize("shard", [(3, 3), (-1, 2), (0, 0), "0/2", 1, (0, 1, 2)])
def test_bad_shard(ctx, tmp, shard):
    with pytest.raises(ValueError):
        ctx.batch([DEFAULT], str(tmp / "{n}.exr"), shard=shard, resolution=8)


def test_two_meshes_one_file(ctx, tmp):
    with pytest.raises(ValueError, match="both write"):
        ctx.batch([DEFAULT, DEFAULT], str(tmp / "{stem}.exr"), resolution=8)
    assert not os.listdir(tmp)
