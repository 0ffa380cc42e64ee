"""inflate_many: independent inflations in worker processes."""

import numpy as np
import pytest


def test_a_failing_run_in_a_worker_reaches_the_caller():
    """strict=True: a run that cannot converge raises ConvergenceError, from the worker process too."""
    from airmat.errors import ConvergenceError
    from inflation.mesh import build_mattress_mesh
    from inflation.model import Parameters
    from inflation.simulate import inflate_many
    from inflation.strings import StringSet

    mesh = build_mattress_mesh(0.6, 0.3, 0.07, resolution=0.05)
    s = StringSet(np.array([[0.15, 0.15]]), np.array([[0.45, 0.15]]), np.array([True]), np.array([0.12]), ("s",))
    with pytest.raises(ConvergenceError):
        inflate_many(mesh, [s, s], params=Parameters(pressure=1e9), strict=True, workers=2)
