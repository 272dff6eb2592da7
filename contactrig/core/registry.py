"""Registries: the one mechanism behind every extension point (contact models, figures, instrument pairs).

A :class:`Registry` maps a key to an item that carries its own ``key``. Built-in items are registered by importing
the modules named in ``builtin_modules`` on the first look-up (so importing the registry stays cheap), and are
remembered as built-in; items registered later (a notebook's, a test's) are used on request. Nothing else in
contactrig keeps a list of names: whatever lists models, figures or pairs asks its registry.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Sequence
from typing import Generic, Protocol, TypeVar

__all__ = ["Keyed", "Registry"]


class Keyed(Protocol):
    @property
    def key(self) -> str: ...


T = TypeVar("T", bound=Keyed)


class Registry(Generic[T]):
    """Items of one kind by key, in registration order (built-ins first). ``what`` names the kind in messages
    ("contact model"); ``builtin_modules`` are imported on the first look-up and register the built-in items."""

    def __init__(self, what: str, builtin_modules: Sequence[str] = ()) -> None:
        self.what = what
        self._builtin_modules = tuple(builtin_modules)
        self._items: dict[str, T] = {}
        self._builtin: set[str] = set()
        self._loaded = not self._builtin_modules

    def _load(self) -> None:
        if not self._loaded:
            self._loaded = True
            for name in self._builtin_modules:
                importlib.import_module(name)
            self._builtin.update(self._items)

    def register(self, item: T, *, replace: bool = False) -> T:
        """Add ``item``; a second item with the same key is a ValueError unless ``replace``."""
        old = self._items.get(item.key)
        if old is not None and old is not item and not replace:
            raise ValueError(f"a {self.what} {item.key!r} is registered already")
        self._items[item.key] = item
        return item

    def unregister(self, key: str) -> None:
        """Remove ``key`` (no error when it is not registered)."""
        self._items.pop(key, None)
        self._builtin.discard(key)

    def get(self, key: str) -> T:
        """The item ``key``; an unknown key is a :class:`KeyError` naming the registered ones."""
        self._load()
        try:
            return self._items[key]
        except KeyError:
            raise KeyError(f"unknown {self.what} {key!r}; registered: {', '.join(self._items)}") from None

    def find(self, key: str) -> T | None:
        """The item ``key``, or None."""
        self._load()
        return self._items.get(key)

    def names(self, *, builtin_only: bool = False) -> tuple[str, ...]:
        """Every key in registration order (``builtin_only``: those contactrig ships)."""
        self._load()
        return tuple(k for k in self._items if not builtin_only or k in self._builtin)

    def __iter__(self) -> Iterator[T]:
        self._load()
        return iter(list(self._items.values()))

    def __contains__(self, key: object) -> bool:
        self._load()
        return key in self._items
