"""The contact-model registry: one class (or builder) plus one registration per model.

Everything that lists contact models — the database build, the rig sweep, the fit, the figures and the report, the
stability atlas and the CLI help — asks this registry instead of keeping a list of names. Adding a model is one
:func:`register` call next to its physics; a test can register a toy model and see it flow through every stage.

A :class:`ContactModel` says how to build its curve on the database's separation grid (``build``), how to show it
(``label``, ``style``) and what it assumes (``elastic_only``: no hardness cap, so a plasticity index > 1 makes its
answer doubtful; ``needs_surface``: it sums over the summits of a generated or measured composite surface, so the
database generates one — models from statistics alone never do; ``default``: built when a scene names no models —
False for a costly reference, built only when asked for).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from contactrig.core.registry import Registry

if TYPE_CHECKING:
    from sims.database import BuildContext, ContactCurve

__all__ = [
    "BUILTIN_MODULES",
    "ContactModel",
    "default_model_names",
    "get_model",
    "model_label",
    "model_names",
    "models",
    "register",
    "unregister",
]

# Modules whose import registers the built-in models (imported lazily, on the first look-up).
BUILTIN_MODULES = ("sims.greenwood_tripp", "sims.asperity", "sims.bem_database")


@dataclass(frozen=True)
class ContactModel:
    """One contact model as the rest of contactrig sees it.

    ``key``: the name in scenes, files and the CLI (``"hertz"``). ``label``: display name (``"Hertz"``).
    ``equations``: where it comes from (``"seed eq. 5–7"``). ``build(ctx) -> ContactCurve``: the curve on the
    database grid from a :class:`sims.database.BuildContext`. ``style``: optional matplotlib keywords (colour,
    linestyle, marker) so the model looks the same in every figure; models without one get a colour from a cycle.
    """

    key: str
    label: str
    build: Callable[[BuildContext], ContactCurve]
    equations: str = ""
    description: str = ""
    elastic_only: bool = False
    needs_surface: bool = True
    default: bool = True
    style: dict[str, Any] = field(default_factory=dict)


_REGISTRY: Registry[ContactModel] = Registry("contact model", BUILTIN_MODULES)


def register(model: ContactModel, *, replace: bool = False) -> ContactModel:
    """Add ``model`` to the registry (a second model with the same key is an error unless ``replace``)."""
    return _REGISTRY.register(model, replace=replace)


def unregister(key: str) -> None:
    """Remove a model (tests use it to clean up a toy model)."""
    _REGISTRY.unregister(key)


def models() -> Iterator[ContactModel]:
    """Every registered model, in registration order (built-ins first)."""
    return iter(_REGISTRY)


def model_names(*, builtin_only: bool = False) -> tuple[str, ...]:
    """The keys of every registered model, in registration order (``builtin_only``: those contactrig ships)."""
    return _REGISTRY.names(builtin_only=builtin_only)


def default_model_names() -> tuple[str, ...]:
    """The models a scene gets when its ``[database]`` names none: the built-in ones marked ``default`` (a costly
    reference such as a boundary-element solution, or a notebook's model, is built only on request)."""
    return tuple(k for k in _REGISTRY.names(builtin_only=True) if _REGISTRY.get(k).default)


def get_model(key: str) -> ContactModel:
    """The model ``key``; an unknown key is a :class:`KeyError` naming the known ones."""
    return _REGISTRY.get(key)


def model_label(key: str) -> str:
    """Display name of model ``key`` (the key itself, made readable, for a model that is not registered)."""
    m = _REGISTRY.find(key)
    return m.label if m is not None else key.replace("_", " ")
