"""The Fortran core's folders are layers: each module uses only modules of its own folder or of
the folders below it (fortran/src/meson.build lists them bottom-up; fortran/src/README.md draws
them), and the executable and the Python API reach the core through the facade `tmafm`."""

import re
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "fortran" / "src"
APP = SRC.parent / "app"
#: Bottom to top.  `facade` is fortran/src/tmafm.f90.
LAYERS = ("base", "physics", "integrators", "config", "solve", "run", "output", "instrument", "facade", "api")
#: Layers that do not use each other (neither is below the other).
SIBLINGS = {frozenset({"run", "output"}), frozenset({"output", "instrument"})}
USE = re.compile(r"^\s*use\s*(?:,\s*non_intrinsic\s*)?(?:::)?\s*(tmafm\w*)", re.I | re.M)


def _modules():
    """{module name: (layer, path)} of every Fortran module of the core."""
    found = {}
    for path in sorted([*SRC.rglob("*.f90"), *SRC.rglob("*.f90.in")]):
        layer = "facade" if path.parent == SRC else path.parent.name
        for name in re.findall(r"^\s*module\s+(tmafm\w*)\s*$", path.read_text(), re.I | re.M):
            found[name.lower()] = (layer, path)
    return found


def _uses(path):
    return {name.lower() for name in USE.findall(path.read_text())}


def test_every_folder_is_a_known_layer_listed_in_meson_build():
    folders = {p.name for p in SRC.iterdir() if p.is_dir()}
    assert folders == set(LAYERS) - {"facade"}
    listed = re.findall(r"subdir\('(\w+)'\)", (SRC / "meson.build").read_text())
    assert tuple(listed) == tuple(layer for layer in LAYERS if layer not in ("facade", "api"))


@pytest.mark.parametrize("name", sorted(_modules()))
def test_a_module_uses_only_its_layer_and_the_layers_below(name):
    modules = _modules()
    layer, path = modules[name]
    rank = LAYERS.index(layer)
    for used in _uses(path) - {name}:
        assert used in modules, f"{path.name} uses {used}, which is not a module of fortran/src"
        used_layer = modules[used][0]
        if frozenset({layer, used_layer}) in SIBLINGS:
            raise AssertionError(f"{path.name} ({layer}/) uses {used} ({used_layer}/): siblings")
        assert LAYERS.index(used_layer) <= rank, \
            f"{path.name} ({layer}/) uses {used} from the layer above, {used_layer}/"


def test_the_executable_uses_only_the_facade():
    assert _uses(APP / "main.f90") == {"tmafm"}


def test_the_python_api_uses_the_facade_and_only_the_types_f90wrap_resolves():
    # f90wrap resolves a wrapped signature's type through the module that defines it, so the API
    # names those types' own modules; every procedure and constant comes through the facade.
    used = _uses(SRC / "api" / "tmafm_api.f90")
    modules = _modules()
    for module in used - {"tmafm", "tmafm_api_poll"}:
        text = (SRC / "api" / "tmafm_api.f90").read_text()
        imported = re.search(rf"use\s+{module}\s*,\s*only\s*:\s*(\w+)\s*$", text, re.I | re.M)
        assert imported and imported.group(1).endswith("_t"), \
            f"tmafm_api uses {module} for more than one type: go through the facade"
        assert modules[module][0] != "api"
