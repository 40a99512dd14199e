"""What a notebook user meets before any result: the errors, the help, the repr and ``dir`` of the API.

The expected texts come from the configuration schema (the one source of every key's type,
default and description) and from the API's own signatures: nothing here is copied from the
code's output.
"""

import inspect
import re
import traceback

import pytest

import ldpipe
from ldpipe.api.keywords import keyword_names, resolved, schema_at
from support.henon_heiles import HENON_HEILES


@pytest.fixture(scope="module")
def hh():
    return ldpipe.system(name="henon_heiles", **HENON_HEILES)


SECTION = {"section": {"axes": [{"name": "y", "range": [-0.45, 0.8], "points": 3},
                                {"name": "py", "range": [-0.5, 0.5], "points": 3}],
                       "fixed": {"px": 0.0}, "solve": "x", "root": "largest"}, "energy": 0.125}


def raised(call):
    """The exception ``call`` raises and the frames of its traceback, as the caller sees them."""
    try:
        call()
    except Exception as error:  # noqa: BLE001  (whatever it is, the test looks at it)
        return error, traceback.extract_tb(error.__traceback__)
    raise AssertionError("no exception raised")


def test_config_error_is_importable_from_the_package():
    from ldpipe import ConfigError, LdpipeError
    from ldpipe.errors import ConfigError as Internal

    assert ConfigError is Internal and issubclass(ConfigError, LdpipeError)


def test_an_api_error_is_one_line_naming_the_argument_without_ldpipe_frames(hh):
    error, frames = raised(lambda: ldpipe.ld_map(hh, tau=-1.0, integrator={"rtol": 5}, **SECTION))
    assert isinstance(error, ldpipe.ConfigError)
    text = str(error)
    assert "\n" not in text
    assert text.startswith("ldpipe.ld_map: ")
    assert "argument 'tau'" in text and "argument 'integrator.rtol'" in text
    # the caller's frame, and at most the API's boundary (which IPython and pytest hide) below it
    inside = [frame for frame in frames if "/ldpipe/" in frame.filename.replace("\\", "/")]
    assert len(inside) <= 1, [f"{frame.filename}:{frame.lineno}" for frame in frames]
    assert error.__cause__ is None and error.__suppress_context__


@pytest.mark.parametrize(("given", "meant"),
                         [("tua", "tau"), ("integrater", "integrator"), ("sadle_near", "saddle_near")])
def test_a_misspelt_keyword_gets_did_you_mean(hh, given, meant):
    # difflib's closest accepted key (the schema's properties of an ld_maps entry)
    assert meant in schema_at("$defs/ld_map")["properties"]
    with pytest.raises(ldpipe.ConfigError, match=rf"unknown arguments \['{given}'\] \(did you mean '{meant}'\?\)"):
        ldpipe.ld_map(hh, **SECTION, **{given: 1.0})


def test_a_keyword_like_no_other_gets_no_guess(hh):
    with pytest.raises(ldpipe.ConfigError) as error:
        ldpipe.ld_map(hh, **SECTION, zzzzzz=1.0)
    assert "did you mean" not in str(error.value)


def test_a_configuration_gets_did_you_mean_too():
    from ldpipe.config import validate_config

    with pytest.raises(ldpipe.ConfigError, match=r"unknown keys \['tua'\] \(did you mean 'tau'\?\)"):
        validate_config({"systems": {"hh": dict(HENON_HEILES)}, "ld_maps": {"m": {"system": "hh", "tua": 1.0}}})


def test_repr_of_a_system_is_one_line_of_what_it_is(hh):
    text = repr(hh)
    assert text == "System('henon_heiles', formula, coordinates=('x', 'y'))"
    barbanis = ldpipe.system(builtin="barbanis_2dof")
    # the paper's parameters (Barbanis: omega_x = 1, omega_y = 1.1, delta = -0.11)
    assert repr(barbanis) == ("System('barbanis_2dof', builtin, coordinates=('x', 'y'), "
                              "parameters={'omega_x': 1.0, 'omega_y': 1.1, 'delta': -0.11})")
    assert "\n" not in repr(barbanis) and "Dispatcher" not in repr(barbanis)


def test_dir_lists_the_public_names_only():
    names = dir(ldpipe)
    assert set(ldpipe.API) <= set(names) and "ConfigError" in names
    assert not [name for name in names if name.startswith("_") and name != "__version__"]
    for internal in ("api", "config", "core", "engine", "systems", "import_module", "accessor", "errors"):
        assert internal not in names
    assert sorted(names) == sorted(ldpipe.__all__)


def _flat(text: str) -> str:
    return " ".join(text.split())


API_KEYWORDS = [(name, getattr(ldpipe, name)) for name in ldpipe.API]


@pytest.mark.parametrize(("name", "function"), API_KEYWORDS)
def test_help_documents_every_keyword_with_its_schema_description(name, function):
    doc = inspect.getdoc(function)
    # every parameter of the signature has its numpydoc entry ("name : type")
    for parameter in inspect.signature(function).parameters.values():
        if parameter.kind in (parameter.VAR_KEYWORD, parameter.VAR_POSITIONAL):
            continue
        entry = rf"^(\w+, )*{parameter.name}(, \w+)* :"  # "solve, sign, root : optional" names three
        assert re.search(entry, doc, re.MULTILINE), f"{name}: {parameter.name}"
    schema, taken = function.schema_keywords
    if schema is None:
        return
    flat = _flat(doc)
    # ... and so has every key the function takes as **keywords, with the schema's type words,
    # default and whole description (hyphenated words may be broken across lines by the wrap)
    for key in keyword_names(schema, taken):
        node = resolved(schema_at(schema)["properties"][key])
        match = re.search(rf"(?m)^{key} : ([^\n]*)$", doc)
        assert match, f"{name}: keyword {key!r} undocumented"
        if "default" in node:
            assert f"default {node['default']!r}" in match.group(1), f"{name}: {key}"
        description = _flat(node.get("description", ""))
        assert description and description.replace(" ", "") in flat.replace(" ", ""), f"{name}: {key}"


def test_a_system_argument_that_is_no_system_is_named(hh):
    with pytest.raises(ldpipe.ConfigError, match=r"^ldpipe.ld_map: argument 'system': expected a system from "
                                                 r"ldpipe.system\(...\), got str 'henon_heiles'$"):
        ldpipe.ld_map("henon_heiles", **SECTION)
    # and the unknown-argument message lists keywords, not the positional system
    with pytest.raises(ldpipe.ConfigError) as error:
        ldpipe.ld_map(hh, **SECTION, zzzzzz=1.0)
    assert "'system'" not in str(error.value) and "'tau'" in str(error.value)
