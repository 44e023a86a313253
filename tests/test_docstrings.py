"""Every public function, class, method and property of the four rooms says what it is (a newcomer
finds any scene, sensor or estimator by its name and reads its shapes and units there)."""

import importlib
import inspect
import pkgutil


def _public(room: str):
    pkg = importlib.import_module(f"calibench.{room}")
    for m in pkgutil.walk_packages(pkg.__path__, prefix=f"calibench.{room}."):
        mod = importlib.import_module(m.name)
        for name, obj in vars(mod).items():
            if name.startswith("_") or getattr(obj, "__module__", None) != mod.__name__:
                continue
            if inspect.isfunction(obj) or inspect.isclass(obj):
                yield f"{mod.__name__}.{name}", obj
            if inspect.isclass(obj):
                for mn, mobj in vars(obj).items():
                    if mn.startswith("_"):
                        continue
                    if isinstance(mobj, property):
                        yield f"{mod.__name__}.{name}.{mn}", mobj
                    elif inspect.isfunction(mobj):
                        yield (
                            f"{mod.__name__}.{name}.{mn}",
                            getattr(obj, mn),
                        )  # inherits the base's doc


def test_every_public_name_has_a_docstring():
    missing = [
        name
        for room in ("estimators", "scenes", "sim", "scenarios")
        for name, obj in _public(room)
        if not inspect.getdoc(obj)
    ]
    assert not missing, missing
