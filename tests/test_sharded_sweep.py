"""Sweeps sharded over several devices (jax.shard_map) are bit-equal to one device's.

The number of CPU devices is fixed when JAX starts, so the multi-device run happens in a
subprocess with ``XLA_FLAGS=--xla_force_host_platform_device_count=4``.

On CPU, XLA compiles the partitioned program with other fusion boundaries than the one-device
program, and LLVM contracts ``a * b + c`` into fused multiply-adds within a fusion: with FMA
instructions available the last bit can differ (seen: 7 % of P1's det_A values, relative
difference up to 3e-15). Without FMA (``--xla_cpu_max_isa=AVX``) the results are bit-equal,
which the test checks; with the default ISA it checks equality to 1e-14 with NaN in place.
"""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import jax
import pytest

import pkmlib as pk

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = textwrap.dedent(
    """
    import sys
    import jax, numpy as np
    import pkmlib as pk
    from pkmlib.mechanisms import gripper_4prr as m, three_rrr as t

    assert len(jax.devices()) == 4, jax.devices()
    p1 = m.Gripper4PRRParams.from_dict(pk.load_params("p1")["mechanism"])
    p2 = t.ThreeRRRParams.from_dict(pk.load_params("p2")["mechanism"])

    def p1_maps(pts, p, phi, s):
        return m.pose_criteria(m.pose(pts[0], pts[1], phi, s), p, speeds=(1.0, 1.0, 1.0),
                               loads=(1.0, 1.0, 1.0), F_pr=100.0, external_load=(10.0, 5.0, 1.0))

    def p2_maps(pt, p):
        return t.pose_criteria(t.pose(pt[0], pt[1], 0.1), p, V=1.0, force=1.0)

    g1 = pk.Grid.from_ranges(x_D=(0.2, 1.2, 0.01), y_D=(-0.25, 0.25, 0.005))   # 101 x 101
    g2 = pk.Grid.from_ranges(x=(-0.1, 0.5, 0.01), y=(-0.1, 0.5, 0.013))       # 61 x 47
    cases = [(p1_maps, g1, (p1, np.deg2rad(20.0), 0.14), True), (p2_maps, g2, (p2,), False)]
    exact = sys.argv[1] == "exact"
    for fn, grid, args, batched in cases:
        one = pk.sweep(fn, grid, args=args, batched=batched, chunk_size=1000)
        for devices in ("all", jax.devices()[:3], jax.sharding.Mesh(np.array(jax.devices()), ("points",))):
            many = pk.sweep(fn, grid, args=args, batched=batched, chunk_size=1000, devices=devices)
            for k in one:
                assert one[k].shape == many[k].shape, k
                np.testing.assert_array_equal(np.isnan(one[k]), np.isnan(many[k]), err_msg=k)
                if exact:
                    np.testing.assert_array_equal(one[k], many[k], err_msg=k)  # bit-equal
                else:
                    ok = np.isfinite(one[k])
                    np.testing.assert_allclose(many[k][ok], one[k][ok], rtol=1e-14, atol=0, err_msg=k)
            assert any(np.isnan(v).any() for v in one.values())
            assert all(np.isfinite(v).any() for v in one.values())
    # the compiled call really is sharded over the four devices
    from pkmlib._sweep import _compiled_for, _mesh
    run, chunk = _compiled_for(p2_maps, g2, 256, False, _mesh("all"), (p2,))
    out = run(np.float64(0), np.asarray(g2.starts), np.asarray(g2.steps), np.asarray(g2.shape, float),
              np.float64(g2.size), *pk._sweep._as_arrays((p2,)))
    q = jax.tree_util.tree_leaves(out)[0]  # the flat leaves, a small one split into its numbers
    assert len(q.sharding.device_set) == 4 and q.shape[0] == 4 * 256
    print("OK")
    """
)


@pytest.mark.parametrize("mode, flags", [("exact", " --xla_cpu_max_isa=AVX"), ("close", "")])
def test_sharded_sweep_equals_one_device(mode, flags):
    env = dict(
        os.environ,
        XLA_FLAGS="--xla_force_host_platform_device_count=4" + flags,
        JAX_PLATFORMS="cpu",
        PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
    )
    # the compilation cache stays on: its keys hash XLA_FLAGS (the device count, the ISA), so these
    # programs never share an entry with the one-device programs of the other tests
    res = subprocess.run([sys.executable, "-c", SCRIPT, mode], env=env, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0 and res.stdout.strip().endswith("OK"), res.stdout + res.stderr


@pytest.mark.parametrize("bad", ["some", 3, [], ["cpu:0"], jax.sharding.Mesh(jax.devices()[:1], ("x",))])
def test_bad_devices_raise_value_errors_naming_devices(bad):
    with pytest.raises(ValueError, match="devices"):
        pk.sweep(lambda pt: pt[0], pk.Grid.from_ranges(a=(0.0, 1.0, 0.5)), devices=bad)


def test_one_listed_device_is_the_same_as_none():
    grid = pk.Grid.from_ranges(a=(0.0, 1.0, 0.01), b=(0.0, 2.0, 0.5))
    f = lambda pt: pt[0] * pt[1] + 1.0  # noqa: E731
    import numpy as np

    np.testing.assert_array_equal(
        pk.sweep(f, grid, devices=jax.devices()[:1], chunk_size=64), pk.sweep(f, grid, chunk_size=64)
    )


HOSTS_SCRIPT = textwrap.dedent(
    """
    import sys
    import jax

    port, pid = sys.argv[1], int(sys.argv[2])
    jax.config.update("jax_cpu_collectives_implementation", "gloo")
    jax.distributed.initialize(coordinator_address=f"127.0.0.1:{port}", num_processes=2, process_id=pid)
    import numpy as np
    import pkmlib as pk
    from pkmlib.mechanisms import three_rrr as t

    assert jax.process_count() == 2 and len(jax.devices()) == 4 and len(jax.local_devices()) == 2
    p2 = t.ThreeRRRParams.from_dict(pk.load_params("p2")["mechanism"])

    def p2_maps(pt, p):
        return t.pose_criteria(t.pose(pt[0], pt[1], 0.1), p, V=1.0, force=1.0)

    grid = pk.Grid.from_ranges(x=(-0.1, 0.5, 0.01), y=(-0.1, 0.5, 0.013))
    many = pk.sweep(p2_maps, grid, args=(p2,), chunk_size=300, devices="all")  # 4 devices, 2 processes
    one = pk.sweep(p2_maps, grid, args=(p2,), chunk_size=300, devices=jax.local_devices()[:1])
    for k in one:
        np.testing.assert_array_equal(np.isnan(one[k]), np.isnan(many[k]), err_msg=k)
        ok = np.isfinite(one[k])
        assert ok.any()
        np.testing.assert_allclose(many[k][ok], one[k][ok], rtol=1e-14, atol=0, err_msg=k)
    print("OK", pid)
    """
)


def test_sweep_across_two_processes_with_jax_distributed():
    """Two processes ("hosts") of two CPU devices each, joined by jax.distributed (gloo
    collectives): every process gets the whole map, equal to its one-device sweep."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = str(s.getsockname()[1])
    env = dict(
        os.environ,
        XLA_FLAGS="--xla_force_host_platform_device_count=2",
        JAX_PLATFORMS="cpu",
        PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
    )
    env.pop("JAX_COMPILATION_CACHE_DIR", None)
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", HOSTS_SCRIPT, port, str(pid)],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for pid in (0, 1)
    ]
    outs = []
    for proc in procs:
        try:
            out, err = proc.communicate(timeout=600)
        except subprocess.TimeoutExpired:
            for other in procs:
                other.kill()
            raise
        outs.append((proc.returncode, out, err))
    for pid, (rc, out, err) in enumerate(outs):
        assert rc == 0 and f"OK {pid}" in out, out + err[-3000:]
