"""contactrig.core.registry: the one mechanism behind contact models, figures and instrument pairs."""

from dataclasses import dataclass

import pytest

from contactrig.core.registry import Registry


@dataclass(frozen=True)
class Item:
    key: str
    value: int = 0


def test_registration_order_duplicates_and_unknown_keys():
    reg: Registry[Item] = Registry("widget")
    a, b = reg.register(Item("a", 1)), reg.register(Item("b", 2))
    assert reg.names() == ("a", "b") and list(reg) == [a, b] and "a" in reg
    assert reg.register(a) is a  # the same object again is harmless
    with pytest.raises(ValueError, match="widget 'a' is registered already"):
        reg.register(Item("a", 3))
    assert reg.register(Item("a", 3), replace=True).value == 3
    with pytest.raises(KeyError, match="unknown widget 'c'; registered: a, b"):
        reg.get("c")
    assert reg.find("c") is None
    reg.unregister("a")
    reg.unregister("a")  # twice is fine
    assert reg.names() == ("b",)


def test_builtins_load_on_first_lookup_and_stay_distinguishable():
    from sims import models

    defaults = {"greenwood_tripp", "hertz", "lagemann", "pasaribu_schipper", "jackson_green"}
    assert set(models.default_model_names()) == defaults
    # the boundary-element reference ships with contactrig but is built only when a scene asks for it
    assert set(models.model_names(builtin_only=True)) == defaults | {"bem"}
    assert not models.get_model("bem").default
    models.register(models.ContactModel("notebook_model", "Notebook", build=lambda ctx: None))
    try:
        assert "notebook_model" in models.model_names()
        assert "notebook_model" not in models.model_names(builtin_only=True)
    finally:
        models.unregister("notebook_model")
