"""``import airmat``: the stage functions and readers/writers, loaded on first use, and short result summaries."""

import json
import subprocess
import sys

import numpy as np
import pytest

import airmat


def test_every_facade_name_resolves_to_the_function_it_names():
    import importlib

    for name, target in airmat._FACADE.items():
        module, _, attr = target.partition(":")
        assert getattr(airmat, name) is getattr(importlib.import_module(module), attr), name
        assert name in dir(airmat) and name in airmat.__all__
    with pytest.raises(AttributeError, match="no_such_stage"):
        airmat.no_such_stage


def test_the_subpackages_stay_modules_beside_the_facade():
    # the facade's names do not shadow a subpackage: airmat.design and airmat.check stay the packages
    import types

    import airmat.check.inflation_check
    import airmat.design.presets

    assert isinstance(airmat.design, types.ModuleType) and isinstance(airmat.check, types.ModuleType)
    assert airmat.design.presets.preset is airmat.preset
    assert airmat.check.inflation_check.check is airmat.check_design
    assert not set(airmat._FACADE) & {"calib", "design", "inflation", "check", "report", "synthetic", "cli"}


def test_import_airmat_loads_no_stage_and_no_numerical_library():
    code = ("import json, sys, airmat; "
            "print(json.dumps(sorted(m for m in sys.modules if m.startswith(('airmat', 'numpy', 'scipy')))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert json.loads(out) == ["airmat"]


def test_monte_carlo_refuses_no_samples():
    from airmat.errors import InputError

    with pytest.raises(InputError, match="at least one sample"):
        airmat.monte_carlo(None, 0)


def test_result_objects_print_as_one_short_line_and_an_html_table():
    from airmat.check.compare import Deviation
    from airmat.design.target import Target

    target, mattress = airmat.preset("vault1")
    dev = Deviation(rms=0.0068, max=0.0309, rms_pct_diag=0.67, per_vertex=np.zeros(5), aligned=np.zeros((5, 3)),
                    surface="top")
    for obj, head, words in [(target, "<Target vault1:", ("vertices", "mm")),
                             (dev, "<Deviation:", ("RMS 6.8 mm", "max 30.9 mm", "0.67"))]:
        text = repr(obj)
        assert text.startswith(head) and text.endswith(">") and "\n" not in text and len(text) < 300, text
        assert all(w in text for w in words), text
        html = obj._repr_html_()
        assert html.startswith("<table>") and all(w.split()[0] in html for w in words)
    assert isinstance(target, Target)


@pytest.mark.slow
def test_a_design_and_its_check_print_short(tmp_path):
    from airmat.design.pipeline import DesignParams

    target, mattress = airmat.preset("vault1")
    result = airmat.make_design(target, mattress, params=DesignParams(spacing=0.04), progress=False)
    text = repr(result)
    assert text.startswith("<DesignResult: target vault1, strings ") and len(text) < 300, text
    assert f"strings {len(result.pattern.strings)}," in text and "constructible True" in text
