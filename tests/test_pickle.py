"""Objects that hold core memory (Config's config_t, Model's model_t) cross process
boundaries as their resolved input, never as a raw handle: a pickled copy works in another
process (multiprocessing, Dask) and gives the same results."""

import multiprocessing
import pickle

import numpy as np

import tmafm

SHORT = {"solver": {"method": "flight_exact", "tau_end": 6.0}, "output": {"sample_dtau": 0.05}}


def test_config_pickle_round_trip_keeps_the_resolved_input():
    config = tmafm.Config("fig2_n4", model={"convention": "consistent"}, **SHORT)
    copy = pickle.loads(pickle.dumps(config))
    assert copy.text == config.text
    assert copy.label == config.label
    assert copy.n_modes == config.n_modes and copy.scene == config.scene
    np.testing.assert_array_equal(copy.run().vt, config.run().vt)


def test_model_pickle_round_trip_gives_the_same_derivative():
    model = tmafm.Model("fig7_dmt")
    copy = pickle.loads(pickle.dumps(model))
    y = np.linspace(-1e-3, 1e-3, 2 * model.n_modes)
    for in_contact in (False, True):
        np.testing.assert_array_equal(copy.derivative(0.3, y, in_contact),
                                      model.derivative(0.3, y, in_contact))


def _vt_in_child(config):
    return config.run().vt


def test_config_runs_in_a_spawned_process():
    config = tmafm.Config("fig4a", **SHORT)
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        # A child that crashed would leave the pool waiting: bound the wait.
        vt = pool.apply_async(_vt_in_child, (config,)).get(timeout=120)
    np.testing.assert_array_equal(vt, config.run().vt)


def test_result_pickles_with_its_config():
    result = tmafm.run("fig2_n4", **SHORT)
    copy = pickle.loads(pickle.dumps(result))
    np.testing.assert_array_equal(copy.vt, result.vt)
