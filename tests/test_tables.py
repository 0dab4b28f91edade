"""The core's key table (fortran/src/config/tmafm_keys.f90) is the one list of namelist keys:
the reader refuses with its ranges, the resolved text writes its defaults, Python types its
keys from it and takes the core's limits, and README's input table and the docs agree with it.
"""

import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

import tmafm
from tmafm._fortran import LIMITS, api, config_t
from tmafm._namelist import GROUPS, KEY_TYPES, KEYS, to_text

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "docs"))
import key_table  # noqa: E402  (docs/key_table.py, the script that writes README's table)

KEY_IDS = [f"{k.group}.{k.name}" for k in KEYS]


def _core(text: str) -> tuple[int, str]:
    """(ierr, message) of the core reading namelist `text` (no Python checks on the way)."""
    ierr, msg = api.config_from_text(text.encode(), b"t.nml", config_t(), False)
    return int(ierr), msg.decode().strip()


def _config_text(text: str) -> str:
    handle = config_t()
    ierr, msg = api.config_from_text(text.encode(), b"t.nml", handle, False)
    assert ierr == 0, msg.decode()
    codes = np.zeros(int(api.config_text_length(handle)), dtype=np.int32)
    api.config_text_codes(handle, codes)
    return codes.astype(np.uint8).tobytes().decode()


# --- README's input table -------------------------------------------------------------------

def _readme_rows() -> dict:
    """{(group, key): {default, unit, range, meaning}} of README's input table."""
    text = (REPO / "README.md").read_text()
    start = text.index("## Input: the namelist groups")
    section = text[start:text.index("\n## ", start + 1)]
    rows, group = {}, None
    for line in section.splitlines():
        if not line.startswith("|") or line.startswith(("| group", "|---")):
            continue
        cells = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line)[1:-1]]
        assert len(cells) == 6, f"README input table: a row of {len(cells)} cells: {line}"
        group_cell, key_cell, default, unit, allowed, meaning = cells
        if group_cell:
            group = re.fullmatch(r"`&(\w+)`", group_cell)[1]
        names = re.findall(r"`(\w+)`", key_cell)
        assert len(names) == 1, f"README input table: one key per row, not {key_cell!r}"
        assert (group, names[0]) not in rows, f"README lists &{group} {names[0]} twice"
        rows[(group, names[0])] = {"default": default.strip("`"), "unit": unit, "range": allowed,
                                   "meaning": meaning}
    return rows


def test_readme_lists_every_key_of_the_core_with_its_default_unit_and_range():
    rows = _readme_rows()
    for key in KEYS:
        row = rows.get((key.group, key.name))
        assert row is not None, f"README's input table lacks &{key.group} {key.name}"
        for field in ("default", "unit", "range", "meaning"):
            assert row[field] == getattr(key, field), \
                f"README &{key.group} {key.name} {field}: {row[field]!r}, the core: {getattr(key, field)!r}"


def test_readme_names_no_key_the_core_does_not_know():
    known = {(k.group, k.name) for k in KEYS}
    unknown = sorted(set(_readme_rows()) - known)
    assert not unknown, f"README's input table lists keys the core does not know: {unknown}"


def test_readme_table_is_the_one_docs_key_table_writes():
    text = (REPO / "README.md").read_text()
    assert key_table.readme_block(text) == key_table.block(), \
        "README's input table is stale: python docs/key_table.py --write"


# --- the docs -------------------------------------------------------------------------------

def test_reliability_md_types_the_keys_as_the_core_does():
    text = (REPO / "docs" / "reliability.md").read_text()
    for kind, label in (("integer", "integer"), ("string", "string"), ("list of reals", "list")):
        row = re.search(rf"^\| {label} \(([^)]*)\)", text, re.M)
        assert row, f"docs/reliability.md: no '{label} (...)' row in the type table"
        listed = re.findall(r"`(\w+)`", row[1])
        core = [k.name for k in KEYS if k.type == kind]
        assert listed == core, f"docs/reliability.md lists {label} keys {listed}, the core {core}"
    assert f"up to {LIMITS['max_modes']} numbers" in text


def test_model_md_names_the_scene_keys_of_the_core():
    text = (REPO / "docs" / "model.md").read_text()
    section = text[text.index("## 2. The dimensionless groups"):text.index("## 3.")]
    listed = [name for row in re.findall(r"^\|[^|]*\|[^|]*\| ([^|]*) \|", section, re.M)
              for name in re.findall(r"`(\w+)`", row)]
    assert listed == list(KEY_TYPES["scene"])


# --- the reader and the writer use the table ------------------------------------------------

#: The defaults the reader resolves: errata 'convention' is written as the list its convention
#: gives (the default 'consistent': all of them).
RESOLVED = {("model", "errata"): "'E1,E2,E3,E4,E6,E7'"}
#: Switches of optional physics, and the output window (tmafm_keys key_t omit_default): the
#: resolved text leaves them out while they have their default (off), so that an input without
#: them writes the text it always wrote.
OFF_SWITCHES = {("scene", "sls_relaxation_time"), ("scene", "sls_modulus_ratio"),
                ("physical", "sample_relaxation_time"), ("physical", "sample_modulus_relaxed"),
                ("scene", "medium_mass"), ("scene", "medium_reynolds"),
                ("physical", "medium_density"), ("physical", "medium_viscosity"),
                ("scene", "vdw_adhesion"), ("scene", "vdw_range"),
                ("physical", "hamaker"), ("physical", "intermolecular_distance")} | \
    {("scene", k) for k in ("electrostatic_strength", "electrostatic_radius", "cone_half_angle",
                            "double_layer_strength", "double_layer_range", "capillary_strength",
                            "capillary_range")} | \
    {("initial", "in_contact"), ("output", "sample_from"), ("output", "last_periods")} | \
    {("scene", "thermal_energy"), ("solver", "thermal_noise"), ("solver", "noise_seed"),
     ("solver", "noise_step")} | \
    {("physical", k) for k in ("tip_bias", "contact_potential", "cone_half_angle", "medium_permittivity",
                               "debye_length", "ionic_strength", "temperature", "tip_surface_potential",
                               "sample_surface_potential", "relative_humidity", "meniscus_rupture_distance",
                               "water_surface_tension", "water_contact_angle")}
#: The drive's tone keys: left out of the resolved text while all four of their group are 0 (a
#: one-tone drive at phase 0 writes what it wrote before tones existed; docs/model.md section 15).
QUIET = {("scene", k) for k in ("alpha2_2", "omega_2", "drive_phase", "drive_phase_2")} | \
    {("physical", k) for k in ("drive_amplitude_2", "drive_angular_frequency_2", "drive_phase", "drive_phase_2")}

#: The &physical keys that replace others (docs/model.md section 12): their default is 'none'
#: (not given); given, they are written back and the keys they replace are not.  Each with what
#: it needs beside it, and the keys it replaces.
ALTERNATIVES = {
    "spring_constant": ("resonance_frequency = 3e5, quality_factor = 400, tip_mass_ratio = 0.05",
                        ("thickness", "density", "tip_mass", "beam_damping")),
    "resonance_frequency": ("spring_constant = 40, quality_factor = 400, tip_mass_ratio = 0.05",
                            ("thickness", "density", "tip_mass", "beam_damping")),
    "quality_factor": ("spring_constant = 40, resonance_frequency = 3e5, tip_mass_ratio = 0.05",
                       ("thickness", "density", "tip_mass", "beam_damping")),
    "tip_mass_ratio": ("spring_constant = 40, resonance_frequency = 3e5, quality_factor = 400",
                       ("thickness", "density", "tip_mass", "beam_damping")),
    "drive_frequency": ("", ("drive_angular_frequency",)),
    "free_amplitude": ("", ("drive_amplitude",)),
    "tip_sample_distance": ("", ("gap", "static_offset")),
    "drive_frequency_2": ("drive_amplitude_2 = 1e-10", ("drive_angular_frequency_2",)),
    "free_amplitude_2": ("drive_angular_frequency_2 = 862507.9046309008", ("drive_amplitude_2",)),
}


#: The instrument's groups (&scan, &fm: docs/instrument.md) need a &physical scene and their
#: required keys (no default of use: 0 is out of range or breaks a rule across keys); their
#: b_ keys (the second material) default to 'none', the first material's value.
INSTRUMENT_PHYSICAL = "&physical free_amplitude = 2e-8, tip_sample_distance = 2.5e-8 /\n"
INSTRUMENT_REQUIRED = {
    "scan": {"scan_length": "4e-8", "pixels": "4", "line_rate": "375.0", "setpoint_ratio": "0.8",
             "lockin_bandwidth": "1e4", "feedback_bandwidth": "1e3"},
    "fm": {"amplitude": "5e-9", "z_start": "1e-8"}}


def _instrument_text(group: str, entry: str, key: str) -> str:
    """&group with `entry` and the group's required keys (but `key`), then a &physical scene;
    the group is on line 1."""
    required = ", ".join(f"{k} = {v}" for k, v in INSTRUMENT_REQUIRED[group].items() if k != key)
    return f"&{group} {entry}, {required} /\n{INSTRUMENT_PHYSICAL}"


def test_the_alternative_keys_are_the_keys_whose_default_is_none():
    assert {k.name for k in KEYS if k.default == "none" and k.group != "scan"} == set(ALTERNATIVES)
    assert {k.name for k in KEYS if k.default == "none" and k.group == "scan"} == \
        {k.name for k in KEYS if k.group == "scan" and k.name.startswith("b_")}


@pytest.mark.parametrize("name", ALTERNATIVES)
def test_an_alternative_key_given_is_written_back_and_the_keys_it_replaces_are_not(name):
    value = {"spring_constant": "40", "resonance_frequency": "3e5", "quality_factor": "400",
             "tip_mass_ratio": "0.05", "drive_frequency": "2e4", "free_amplitude": "1e-8",
             "tip_sample_distance": "2e-9", "drive_frequency_2": "137272.39647784093",
             "free_amplitude_2": "1e-10"}[name]
    companions, replaced = ALTERNATIVES[name]
    text = _config_text(f"&physical {name} = {value}, {companions} /\n")
    written = {line.split(" = ")[0].strip(): line.split(" = ")[1] for line in text.splitlines()
               if " = " in line and not line.lstrip().startswith("!")}
    assert float(written[name]) == float(value)
    assert not set(replaced) & set(written)
    # The keys it replaces are derived: the header says their values.
    assert all(f"! derived: {key} = " in text for key in replaced if key != "thickness"
               and key != "density")
    # The written text reads back to itself.
    assert _config_text(text) == text


@pytest.mark.parametrize("key", KEYS, ids=KEY_IDS)
def test_a_key_given_its_default_is_read_and_written_back_as_the_default(key):
    # An empty default is a row that key_value_text does not write; a key the group's reader
    # does not store is refused ("in the key table but not read").  An alternative key's
    # default is 'none' (not given): test_an_alternative_key_given_... reads and writes it.
    assert key.default
    if key.name in ALTERNATIVES:
        return
    if key.group in INSTRUMENT_REQUIRED:
        if key.default == "none" or key.name in INSTRUMENT_REQUIRED[key.group] or key.name == "z_end":
            # A b_ key not given, a required key, z_end (z_start's with one point): not defaults
            # to give (tests/test_instrument_cli.py reads and writes them).
            return
        text = _config_text(_instrument_text(key.group, f"{key.name} = {key.default}", key.name))
        assert f"\n    {key.name} = {key.default}\n" in text
        return
    text = _config_text(f"&{key.group} {key.name} = {key.default} /\n")
    written = RESOLVED.get((key.group, key.name), key.default)
    if (key.group, key.name) in OFF_SWITCHES | QUIET:
        assert f"\n    {key.name} = " not in text
        return
    assert f"\n    {key.name} = {written}\n" in text


def test_the_resolved_text_of_no_input_holds_every_default_in_the_table_order():
    scene = _config_text("&model /\n").splitlines()
    physical = _config_text("&physical /\n").splitlines()
    for key in KEYS:
        if (key.group, key.name) in QUIET or key.group in INSTRUMENT_REQUIRED:
            continue
        lines = physical if key.group == "physical" else scene
        if key.name in ALTERNATIVES:
            # Not given: not written (test_an_alternative_key_given_...).
            assert not any(line.startswith(f"    {key.name} = ") for line in lines), key
            continue
        written = RESOLVED.get((key.group, key.name), key.default)
        if (key.group, key.name) in OFF_SWITCHES:
            assert not any(line.startswith(f"    {key.name} = ") for line in lines), key
            continue
        assert f"    {key.name} = {written}" in lines, key
    keys = [line.split(" = ")[0].strip() for line in scene if " = " in line]
    assert keys == [k.name for k in KEYS if k.group != "physical" and k.group not in INSTRUMENT_REQUIRED
                    and (k.group, k.name) not in OFF_SWITCHES | QUIET]


def _bounds(allowed: str):
    """(lower, lower closed, upper, upper open, the bounds' text) of a real range text (a rule
    across keys may follow the bounds), or None."""
    m = re.fullmatch(r"(finite, (>=|>) (\S+) and (<=|<) ([^,\s]+))(, .*)?", allowed)
    if not m or m[5].startswith("&"):
        return None
    return float(m[3]), m[2] == ">=", float(m[5]), m[4] == "<", m[1]


REAL_KEYS = [k for k in KEYS if k.type == "real" and _bounds(k.range)]


@pytest.mark.parametrize("key", REAL_KEYS, ids=[f"{k.group}.{k.name}" for k in REAL_KEYS])
def test_a_real_out_of_its_range_is_refused_with_the_range_of_the_table(key):
    lower, lower_closed, upper, upper_open, bounds = _bounds(key.range)
    beyond = [upper + max(abs(upper), 1.0), lower - max(abs(lower), 1.0), math.nan, math.inf]
    if not lower_closed:
        beyond.append(lower)
    if upper_open:
        beyond.append(upper)
    for value in beyond:
        written = repr(value)
        ierr, msg = _core(f"&{key.group} {key.name} = {written} /\n")
        said = f"&{key.group} {key.name} = {written}: must be {bounds}"
        if key.name == "mode_horizon" and upper < value < math.inf:
            # Above its bound mode_horizon says why (tests/test_auto_modes_bound.py).
            said = f"&model mode_horizon = {written}: must be > 0 and <= {bounds.split()[-1]}: with"
        assert ierr == 2 and said in msg, msg
    for value in [upper] * (not upper_open) + [lower] * lower_closed:
        # The bound itself passes this key's range check (a check across keys may refuse it).
        ierr, msg = _core(f"&{key.group} {key.name} = {value!r} /\n")
        assert f"{key.name} = {value!r}: must be {bounds}" not in msg, msg


INT_KEYS = [k for k in KEYS if k.type == "integer"]


@pytest.mark.parametrize("key", INT_KEYS, ids=[f"{k.group}.{k.name}" for k in INT_KEYS])
def test_an_integer_out_of_its_range_is_refused_with_the_range_of_the_table(key):
    lower, upper = map(int, re.match(r"(-?\d+)\.\.(\d+)", key.range).groups())
    also = [0] if "(or 0" in key.range else []
    for value in (upper + 1, lower - 1 if lower - 1 not in also else lower - 2):
        ierr, msg = _core(f"&{key.group} {key.name} = {value} /\n")
        assert ierr == 2 and msg.endswith(f"= {value}: must be in {key.range} (line 1)"), msg
    for value in (lower, *also):
        ierr, msg = _core(f"&{key.group} {key.name} = {value} /\n")
        assert f"= {value}: must be" not in msg, msg


def test_an_unknown_key_is_refused_naming_the_keys_of_its_group_from_the_table():
    for group in GROUPS:
        ierr, msg = _core(f"&{group} no_such_key = 1 /\n")
        names = ", ".join(KEY_TYPES[group])
        assert ierr == 2 and f"unknown key (&{group} keys: {names})" in msg, msg
    ierr, msg = _core("&nope /\n")
    assert f"(known: {', '.join('&' + g for g in GROUPS)})" in msg, msg


def test_a_word_key_takes_exactly_the_words_of_the_table():
    for key in (k for k in KEYS if k.type == "string" and k.range.startswith("'")):
        words = re.findall(r"'(\w+)'", key.range)
        def text(word, method=""):
            if key.group in INSTRUMENT_REQUIRED:
                return _instrument_text(key.group, f"{key.name} = '{word}'", key.name)
            return f"&{key.group} {key.name} = '{word}' /\n{method}"
        for word in words:
            # (a JKR neck needs a method that locates its pull-off: the default rk4_paper refuses it)
            method = "&solver method = 'dop853' /\n" if word == "jkr" else ""
            # (a sphere needs its radius)
            word_text = text(word.upper(), method).replace(", ", ", sphere_radius = 1e-8, ", 1) \
                if word == "sphere" else text(word.upper(), method)
            assert _core(word_text)[0] == 0, _core(word_text)[1]
        ierr, msg = _core(text(words[0] + "x"))
        assert ierr == 2 and msg.endswith(f": must be {key.range} (line 1)"), msg


# --- Python agrees with the core ------------------------------------------------------------

def _as_text(value) -> str:
    """A Python value as a namelist would spell it."""
    if isinstance(value, bool):
        return ".true." if value else ".false."
    if isinstance(value, str):
        return "'" + value + "'"
    if isinstance(value, list):
        return ", ".join(map(_as_text, value))
    return repr(value) if isinstance(value, float) else str(value)


#: What the core says when it refuses a value for its type (not its range).
CORE_TYPE_ERRORS = ("must be a number", "must be an integer", "must be a quoted string",
                    "a string must be quoted", "takes one value")
VALUES = [1, -1, 2.0, 0.5, math.nan, math.inf, -math.inf, "x", "dmt", [0.1, 0.2], True, 10**30]


@pytest.mark.parametrize("key", KEYS, ids=KEY_IDS)
def test_python_refuses_a_value_only_where_the_core_does(key):
    for value in VALUES:
        try:
            to_text({key.group: {key.name: value}})
            python_refuses = None
        except tmafm.InputError as exc:
            python_refuses = str(exc)
        ierr, msg = _core(f"&{key.group} {key.name} = {_as_text(value)} /\n")
        if python_refuses:
            assert ierr != 0, f"Python refuses {value!r} ({python_refuses}); the core takes it"
        else:
            assert not any(e in msg for e in CORE_TYPE_ERRORS), \
                f"Python passes {value!r} on, the core refuses its type: {msg}"


def test_python_takes_the_types_and_scene_keys_from_the_core():
    assert {k.type for k in KEYS} == {"integer", "real", "string", "list of reals"}
    assert tmafm.SCENE_KEYS == tuple(k.name for k in KEYS if k.group == "scene")
    # No copy of a group's key list is left in the package's sources.
    for path in (REPO / "pywrap" / "tmafm").glob("*.py"):
        source = path.read_text()
        for group in GROUPS:
            names = KEY_TYPES[group]
            quoted = [n for n in names if f'"{n}"' in source or f"'{n}'" in source]
            assert len(quoted) < max(3, len(names)), f"{path.name} spells out the &{group} keys {quoted}"


class _CoreReached(Exception):
    pass


def _no_core(*args, **kwargs):
    raise _CoreReached


@pytest.mark.parametrize("option, limit", [("harmonics", "max_harmonics"), ("p_max", "max_p_max"),
                                           ("max_periods", "max_observed_periods"),
                                           ("steady_repeats", "max_observed_periods")])
def test_observe_refuses_by_itself_with_the_core_limits(option, limit, monkeypatch):
    # Python refused only above 10**7 (harmonics = 10**6 had max_periods x 10**6 doubles
    # allocated per output before the core refused it): now it refuses above the core's limit
    # without reaching the core, and passes the limit itself on.
    from tmafm._fortran import api
    most = LIMITS[limit]
    config = tmafm.Config("fig2_n1", solver={"tau_end": 1.0})
    with monkeypatch.context() as patch:
        patch.setattr(api, "batch_run", _no_core)
        with pytest.raises(tmafm.InputError, match=rf"^observe {option} = {most + 1}: must be 1 to {most}$"):
            tmafm.observe(config, **{option: most + 1})
        with pytest.raises(_CoreReached):
            tmafm.observe(config, **{option: most})
    if option in ("harmonics", "p_max"):
        # The core's own check, Python's bypassed, refuses the same value by the same bound.
        monkeypatch.setitem(LIMITS, limit, most + 10)  # the dict observe checks against
        with pytest.raises(tmafm.InputError, match=rf"observe {option} = {most + 1}: must be 1 to {most}$"):
            tmafm.observe(config, max_periods=1, **{option: most + 1})


# --- the core's observable table (fortran/src/solve/tmafm_observable_table.f90) ---------------

def _core_observables() -> list[dict]:
    """The observable table read straight from tmafm_api observable_entry (not through Python's
    copy in tmafm._fortran)."""
    rows = []
    for k in range(1, int(api.observable_count()) + 1):
        name, group, bit, unit, si_unit, scale, kind, index = api.observable_entry(k)
        rows.append({"name": name.decode().strip(), "group": group.decode().strip(), "bit": int(bit),
                     "unit": unit.decode().strip(), "si_unit": si_unit.decode().strip(),
                     "scale": scale.decode().strip(), "kind": kind.decode().strip(),
                     "index": int(index)})
    return rows


def test_the_observe_tables_are_the_cores():
    import importlib

    ob = importlib.import_module("tmafm.observe")

    rows = _core_observables()
    assert len(rows) == 29 and len({r["name"] for r in rows}) == 29
    assert list(api.observable_entry(len(rows) + 1))[2] == 0  # beyond the table: blank
    columns = sorted((r for r in rows if r["kind"] == "column"), key=lambda r: r["index"])
    assert ob.OBSERVABLES == tuple(r["name"] for r in columns)
    assert [r["index"] for r in columns] == list(range(1, 22))
    modal = sorted((r for r in rows if r["kind"] == "modal"), key=lambda r: r["index"])
    assert ob.MODAL_EXTREMA == tuple(r["name"] for r in modal)
    assert ob.UNITS == {r["name"]: r["unit"] for r in rows}
    assert ob.PHYSICAL_UNITS == {r["name"]: r["si_unit"] for r in rows if r["si_unit"]}
    groups = {}
    for r in rows:
        groups.setdefault(r["group"], []).append(r["name"])
    always = groups.pop("always")
    assert {g: set(v) for g, v in ob.OBSERVABLE_GROUPS.items()} == {g: set(v) for g, v in groups.items()}
    assert ob._GROUP_BITS == {r["group"]: r["bit"] for r in rows if r["group"] != "always"}
    assert set(ob._GROUP_BITS.values()) == {1, 2, 4, 8}
    assert all(r["bit"] == 0 for r in rows if r["group"] == "always")
    assert set(ob.ALWAYS) | {"poincare"} == set(always)
    # Every name in a group is an observable Python reports (a column, or one it adds).
    reported = set(ob.UNITS)
    assert all(set(v) <= reported for v in ob.OBSERVABLE_GROUPS.values())


_DOC_UNITS = str.maketrans({"²": "^2", "³": "^3", "τ": "tau", "µ": "u"})


def _doc_table(text: str, header: str) -> list[list[str]]:
    """The cells of the markdown table whose header line starts with `header`."""
    start = text.index(header)
    rows = []
    for line in text[start:].splitlines()[2:]:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip().strip("|").split(" | ")])
    return rows


def test_observables_md_tables_are_the_cores():
    text = (REPO / "docs" / "observables.md").read_text()
    rows = {r["name"]: r for r in _core_observables()}
    # The quantities table: every observable once, with its model and SI-derived units.
    seen = set()
    for cells in _doc_table(text, "| name | definition | unit |"):
        names = re.findall(r"`(\w+)`", cells[0])
        units, si = (c.translate(_DOC_UNITS) for c in (cells[2], cells[3]))
        split = [units.split(", "), si.split(", ")]
        for j, name in enumerate(names):
            assert name in rows and name not in seen, f"docs/observables.md lists {name!r}"
            seen.add(name)
            unit = split[0][j] if len(names) > 1 and len(split[0]) == len(names) else units
            si_unit = split[1][j] if len(names) > 1 and len(split[1]) == len(names) else si
            assert unit == rows[name]["unit"], f"docs/observables.md: unit of {name}"
            assert (si_unit if si_unit != "none" else "") == rows[name]["si_unit"], \
                f"docs/observables.md: SI-derived unit of {name}"
    assert seen == set(rows)
    # The group table ("Selecting observables"): every observable in its group.
    groups = {}
    for cells in _doc_table(text, "| group | observables |"):
        group = re.fullmatch(r"`(\w+)`", cells[0])
        groups[group[1] if group else "always"] = set(re.findall(r"`(\w+)`", cells[1]))
    core = {}
    for r in rows.values():
        core.setdefault(r["group"], set()).add(r["name"])
    assert groups == core


def _table_factors(config) -> np.ndarray:
    factors = np.zeros(int(api.observable_count()))
    ierr, msg = api.observable_table_factors(config._f, factors)
    assert ierr == 0, msg
    return factors


@pytest.mark.parametrize("extra", [
    # A viscoelastic sample, so that dissipated_viscoelastic has values.
    {"sample_relaxation_time": 3e-6, "sample_modulus_relaxed": 0.4e9},
    # A second tone (6 omega), so that the tone columns have values.
    {"drive_amplitude_2": 1e-10, "drive_angular_frequency_2": 6 * 143751.31743848347}])
def test_the_factor_column_is_observable_factors_and_the_scales_of_eq12(extra):
    config = tmafm.Config("physical_polystyrene", solver={"method": "dop853"}, physical=extra)
    # The columns the other switch feeds stay 0 here (the other case checks them).
    idle = {"dissipated_viscoelastic"} if "drive_amplitude_2" in extra else {"tone2_amplitude", "tone2_phase"}
    # Hertz: the least force in contact is 0, at the contact's edges (the factor is checked above).
    idle.add("min_force")
    # No JKR neck here: its channel's SI value is checked against the loop's area in test_jkr.py.
    idle.add("dissipated_adhesion")
    rows = _core_observables()
    factors = _table_factors(config)
    # Oracle: the scales of Eq. (10)-(12) from the &physical values, written out here.
    phys = config.to_dict()["physical"]
    ei = phys["youngs_modulus_tip"] * phys["width"] * phys["thickness"] ** 3 / 12
    m = phys["density"] * phys["width"] * phys["thickness"]
    length, d = phys["length"], phys["gap"]
    oracle = {"": 0.0, "one": 1.0, "length": d * 1e9, "time": math.sqrt(m * length ** 4 / ei) * 1e6,
              "force": ei / length ** 2 * 1e9, "energy": ei * d ** 2 / length ** 3 * 1e18,
              "force_length": ei / length ** 2 * d * 1e18}
    for r, factor in zip(rows, factors, strict=True):
        assert factor == pytest.approx(oracle[r["scale"]], rel=1e-12), r["name"]
    # The core's observable_factors (what Observation.physical is multiplied by) agree with the
    # table's column for column, and Python converts the other rows with the table's factor.
    obs = tmafm.observe(config, max_periods=4, stop_at_steady=False)
    for r, factor in zip(rows, factors, strict=True):
        if r["name"] == "poincare":
            assert r["name"] not in obs.physical
            continue
        model, physical = obs.per_period[r["name"]], obs.physical[r["name"]]
        usable = np.isfinite(model) & (model != 0)
        if r["name"] in idle:
            continue
        assert usable.any(), r["name"]
        np.testing.assert_allclose(physical[usable] / model[usable], factor, rtol=1e-14,
                                   err_msg=r["name"])
    # A wrong size is refused.
    ierr, msg = api.observable_table_factors(config._f, np.zeros(3))
    assert ierr != 0 and "observable_count" in msg.decode()
