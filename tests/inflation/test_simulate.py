"""inflate_many: independent inflations through the executor (serial, or Dask worker processes)."""

import numpy as np
import pytest


def test_a_failing_run_in_a_worker_reaches_the_caller():
    """strict=True: a run that cannot converge raises ConvergenceError, from the worker process too."""
    from airmat.errors import ConvergenceError
    from airmat.inflation.mesh import build_mattress_mesh
    from airmat.inflation.model import Parameters
    from airmat.inflation.simulate import inflate_many
    from airmat.inflation.strings import StringSet

    mesh = build_mattress_mesh(0.6, 0.3, 0.07, resolution=0.05)
    s = StringSet(np.array([[0.15, 0.15]]), np.array([[0.45, 0.15]]), np.array([True]), np.array([0.12]), ("s",))
    with pytest.raises(ConvergenceError):
        inflate_many(mesh, [s, s], params=Parameters(pressure=1e9), strict=True, workers=2)


def test_the_executor_gives_the_serial_results_byte_for_byte():
    """Two local Dask workers: the same Inflation arrays, bit for bit, as one after the other; the mesh is the caller's."""
    from airmat.inflation.mesh import build_mattress_mesh
    from airmat.inflation.simulate import inflate_many
    from airmat.inflation.strings import StringSet

    mesh = build_mattress_mesh(0.6, 0.3, 0.07, resolution=0.05)
    sets = [StringSet(np.array([[0.15, 0.15]]), np.array([[0.45, 0.15]]), np.array([True]), np.array([r]), ("s",))
            for r in (0.22, 0.25)]
    serial = inflate_many(mesh, sets, workers=1)
    dask = inflate_many(mesh, sets, workers=2)
    for a, b in zip(serial, dask):
        assert a.xyz.tobytes() == b.xyz.tobytes() and a.string_lengths.tobytes() == b.string_lengths.tobytes()
        assert (a.n_iter, a.residual, a.energy) == (b.n_iter, b.residual, b.energy)
        assert b.mesh is mesh
    assert serial[0].xyz.tobytes() != serial[1].xyz.tobytes()


def test_one_run_does_not_import_dask():
    """Start-up stays light: a single run (or workers=1) goes through the executor without Dask."""
    import subprocess
    import sys

    code = ("import numpy as np, sys\n"
            "from airmat.inflation.executor import map_shared\n"
            "assert map_shared(lambda s, x: s + x, 1, [1], workers=4) == [2]\n"
            "assert map_shared(lambda s, x: s + x, 1, [1, 2], workers=1) == [2, 3]\n"
            "print('distributed' in sys.modules, 'dask' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


def test_a_local_cluster_does_not_need_port_8787(recwarn):
    """Two runs at once (or any program on Dask's default port 8787) must not collide: the scheduler's
    HTTP routes take a free port (it warned, and under pytest's warnings-as-errors failed, before)."""
    import operator
    import socket

    from airmat.inflation.executor import map_shared

    holder = socket.socket()
    try:
        try:
            holder.bind(("127.0.0.1", 8787))
            holder.listen(1)
        except OSError:
            pass                      # already held by something else: the same condition
        assert map_shared(operator.add, 1, [1, 2], workers=2) == [2, 3]
    finally:
        holder.close()
    assert not [w for w in recwarn if "already in use" in str(w.message)]


def _two_lengths():
    from airmat.inflation.mesh import build_mattress_mesh
    from airmat.inflation.strings import StringSet

    mesh = build_mattress_mesh(0.6, 0.3, 0.07, resolution=0.05)
    sets = [StringSet(np.array([[0.15, 0.15]]), np.array([[0.45, 0.15]]), np.array([True]), np.array([r]), ("s",))
            for r in (0.25, 0.22)]
    return mesh, sets


def test_inflate_from_carries_an_equilibrium_on_to_other_strings():
    """A refined design's path (inflate_from): Newton from an equilibrium, to the full tolerance, on its mesh."""
    from airmat.inflation.simulate import INFLATE_TOL, inflate, inflate_from

    mesh, (s1, s2) = _two_lengths()
    start = inflate(mesh, s1)
    same = inflate_from(start, s1)                     # already there: no Newton step
    assert same.converged and same.n_iter == 0 and same.xyz.tobytes() == start.xyz.tobytes()
    moved = inflate_from(start, s2)
    assert moved.converged and moved.residual < INFLATE_TOL and moved.mesh is mesh and moved.stages == 1
    assert 0 < moved.n_iter < start.n_iter             # a few Newton steps, not a whole inflation
    # the string is shorter: its ends come closer, to what the same strings inflated from flat give
    assert moved.string_lengths[0] < start.string_lengths[0]
    flat = inflate(mesh, s2)
    assert abs(moved.string_lengths[0] - flat.string_lengths[0]) < 1e-3
    untied = inflate_from(start, None)                 # every string untied at once
    assert untied.converged and untied.string_lengths.size == 0


def test_inflate_many_from_a_start_is_inflate_from_each():
    """inflate_many(start=...): every run carried on from the same equilibrium, serial or on Dask workers."""
    from airmat.inflation.simulate import inflate, inflate_from, inflate_many

    mesh, (s1, s2) = _two_lengths()
    start = inflate(mesh, s1)
    one = inflate_from(start, s2)
    for workers in (1, 2):
        got = inflate_many(mesh, [s2, s1], start=start, workers=workers)
        assert got[0].xyz.tobytes() == one.xyz.tobytes() and got[0].mesh is mesh
        assert got[1].n_iter == 0
