"""The Registry type: registration, did-you-mean errors, duplicates, package discovery."""

import sys
import textwrap

import pytest

from simcalib.errors import ConfigError, ConfigTypeError, UsageError
from simcalib.registry import Registry, discover


def test_register_get_available_and_decorator():
    reg = Registry("widget", key="widget")
    reg.register("round", dict, colour="red")

    @reg.register("square", colour="blue")
    def square():
        return 4

    assert reg.get("round") is dict and reg.get("square") is square and square() == 4
    assert list(reg.available()) == ["round", "square"] == reg.names()
    assert reg.info("square")["colour"] == "blue" and "round" in reg and len(reg) == 2
    with pytest.raises(TypeError):
        reg.info("square")["colour"] = "green"          # metadata is read-only


def test_unknown_name_names_the_closest_and_lists_all():
    reg = Registry("widget", key="world.widget")
    for name in ("round", "square", "triangle"):
        reg.register(name, object())
    with pytest.raises(ConfigError) as exc:
        reg.get("sqare")
    msg = str(exc.value)
    assert "unknown widget 'sqare'" in msg and "did you mean 'square'" in msg
    assert msg.startswith("world.widget:") and "round, square, triangle" in msg
    with pytest.raises(ConfigTypeError, match="world.widget must be a string; received int"):
        reg.get(3)
    usage = Registry("command", error=UsageError)
    with pytest.raises(UsageError, match=r"unknown command 'x'; available: \(none\)"):
        usage.get("x")


def test_duplicate_registration_is_refused_naming_the_first():
    reg = Registry("widget")
    first = object()
    reg.register("a", first)
    assert reg.register("a", first) is first              # the same object again: no-op
    with pytest.raises(ValueError, match="widget 'a' is already registered"):
        reg.register("a", object())
    with pytest.raises(TypeError, match="non-empty string"):
        reg.register("", object())


def test_info_factory_and_check():
    def make(name, obj, *, size):
        return (name, obj, size)

    def check(name, obj):
        if not callable(obj):
            raise TypeError(f"{name} is not callable")

    reg = Registry("gadget", info=make, check=check)
    reg.register("big", len, size=3)
    assert reg.info("big") == ("big", len, 3)
    with pytest.raises(TypeError, match="not callable"):
        reg.register("bad", 5, size=1)
    assert "bad" not in reg


def test_object_carrying_info_is_described_by_it():
    class Thing:
        info = ("thing", "facts")
    reg = Registry("thing")
    reg.register("t", Thing())
    assert reg.available() == {"t": ("thing", "facts")}


def _plugin_package(root, name):
    pkg = root / name
    pkg.mkdir()
    (pkg / "__init__.py").write_text(textwrap.dedent("""
        from simcalib.registry import Registry
        THINGS = Registry("thing", package=__name__)
    """))
    for mod in ("beta", "alpha"):
        (pkg / f"{mod}.py").write_text(textwrap.dedent(f"""
            from {name} import THINGS
            IMPORTS = globals().get("IMPORTS", 0) + 1
            THINGS.register("{mod}", IMPORTS, origin=__name__)
        """))
    (pkg / "_private.py").write_text("raise RuntimeError('a _module is never imported')\n")
    (pkg / "__main__.py").write_text("raise RuntimeError('__main__ is never imported')\n")
    return pkg


def test_discovery_imports_each_module_of_a_package_once_on_first_lookup(tmp_path,
                                                                         monkeypatch):
    _plugin_package(tmp_path, "simcalib_plugins_t1")
    monkeypatch.syspath_prepend(str(tmp_path))
    import simcalib_plugins_t1 as pkg
    try:
        assert "simcalib_plugins_t1.alpha" not in sys.modules          # lazy
        assert pkg.THINGS.names() == ["alpha", "beta"]                   # file-name order
        assert pkg.THINGS.info("beta")["origin"] == "simcalib_plugins_t1.beta"
        assert pkg.THINGS.get("alpha") == 1 and len(pkg.THINGS) == 2    # imported once
        with pytest.raises(ConfigError, match="did you mean 'alpha'"):
            pkg.THINGS.get("alpah")
        # a new file dropped into the folder is found by discover() with no other edit
        (tmp_path / "simcalib_plugins_t1" / "gamma.py").write_text(
            "from simcalib_plugins_t1 import THINGS\nTHINGS.register('gamma', 3)\n")
        import importlib
        importlib.invalidate_caches()
        assert "simcalib_plugins_t1.gamma" in discover("simcalib_plugins_t1")
        assert pkg.THINGS.get("gamma") == 3
    finally:
        for m in [m for m in sys.modules if m.startswith("simcalib_plugins_t1")]:
            del sys.modules[m]


def test_a_broken_module_is_an_error_not_a_missing_entry(tmp_path, monkeypatch):
    pkg = _plugin_package(tmp_path, "simcalib_plugins_t2")
    (pkg / "broken.py").write_text("import a_module_that_does_not_exist_anywhere\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    import simcalib_plugins_t2 as mod
    try:
        with pytest.raises(ModuleNotFoundError):
            mod.THINGS.get("alpha")
    finally:
        for m in [m for m in sys.modules if m.startswith("simcalib_plugins_t2")]:
            del sys.modules[m]


def test_discover_needs_a_package():
    with pytest.raises(TypeError, match="not a package folder"):
        discover("simcalib.registry")
