"""Optional physics that is not combined (docs/model.md sections 6a, 13-15): the stroboscopic map
of a viscoelastic sample or of a general drive.  Each is refused in one line naming the key and
its value, never run with a kernel that leaves a term out.  (The parts themselves compose:
tests/test_compose.py.)"""

import pytest

import tmafm
from tmafm import continuation as cont

TONE = {"alpha2_2": 1e-5, "omega_2": 6.0}


@pytest.mark.parametrize("scene", [{"sls_relaxation_time": 1.0, "sls_modulus_ratio": 0.5}, TONE],
                         ids=["sls", "tone"])
def test_the_stroboscopic_map_refuses_what_it_does_not_model(scene):
    model = tmafm.Model("fig2_n4", scene=scene, solver={"method": "dop853"})
    with pytest.raises(tmafm.InputError, match="stroboscopic map"):
        cont.periodic_map(model, [0.0] * (2 * model.n_modes), 1, 1e-9)
