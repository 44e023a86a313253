"""What the machines are: nominal geometry -> MJCF (+ texture assets), one module per scene.

A scene module that builds a whole machine says so with ``default_scenes()``: {label: () ->
(MJCF, assets)} with its default geometry (the arms': one per built-in arm). Each imports what
it draws when called: importing one scene (a Monte-Carlo worker's) loads no other, and not
OpenCV, which only the camera scenes' textures need. :func:`scenes` collects them all.
"""

from collections.abc import Callable


def scenes() -> dict[str, Callable[[], tuple[str, dict]]]:
    """Every scene module's default scenes, labelled ``module`` or ``module/label``."""
    import importlib
    import pkgutil

    out = {}
    for info in pkgutil.iter_modules(__path__):
        module = importlib.import_module(f"{__name__}.{info.name}")
        for label, build in getattr(module, "default_scenes", dict)().items():
            out[f"{info.name}/{label}" if label else info.name] = build
    return out
