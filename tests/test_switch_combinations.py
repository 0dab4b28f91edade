"""The stroboscopic map takes each optional physics the model takes (docs/model.md §16;
tests/test_continuation_physics.py checks its monodromy matrices); what it cannot take, a state
outside the model's, it refuses in one line.  (The parts themselves compose:
tests/test_compose.py.)"""

import pytest

import tmafm
from tmafm import continuation as cont

TONE = {"alpha2_2": 1e-5, "omega_2": 6.0}


@pytest.mark.parametrize("scene, law, size", [
    ({"sls_relaxation_time": 1.0, "sls_modulus_ratio": 0.5}, "hertz", 9),
    (TONE, "hertz", 8), ({"drive_phase": 0.3}, "hertz", 8), ({}, "dmt_vdw", 8),
], ids=["sls", "tone", "phase", "vdw"])
def test_the_stroboscopic_map_takes_the_optional_physics(scene, law, size):
    """The map of a viscoelastic sample has the state (a, adot, w), 2N + 1; the others (a, adot)."""
    model = tmafm.Model("fig2_n4", scene=scene, model={"contact_law": law}, solver={"method": "dop853"})
    assert cont.map_size(model) == size
    out = cont.periodic_map(model, [0.0] * size, 1, 1e-9)
    assert out.y.shape == (size,) and out.monodromy.shape == (size, size)


def test_the_stroboscopic_map_refuses_a_negative_dashpot_coordinate():
    model = tmafm.Model("fig2_n4", scene={"sls_relaxation_time": 1.0, "sls_modulus_ratio": 0.5},
                        solver={"method": "dop853"})
    with pytest.raises(tmafm.InputError, match="stroboscopic map: the dashpot coordinate w = -1") as info:
        cont.periodic_map(model, [0.0] * 8 + [-1.0], 1, 1e-9)
    assert "\n" not in str(info.value)
