# Copyright 2026 sma_actuator developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Plug-in point: add your own effect to the catalog without editing the package.

Three ways, all ending in `sma_actuator.workbench.effects.register_effect(cls)`:

1. ``sma-model ... --plugin path/to/my_effect.py`` – a Python file;
2. ``sma-model ... --plugin my_package.my_effect`` – an importable module name;
3. an installed distribution declaring the entry-point group ``sma_actuator.effects``
   (``entry_points={'sma_actuator.effects': ['my_effect = my_package.my_effect:MyEffect']}``);
   the entry point may name the Effect subclass or a module.

A plug-in module defines a subclass of `Effect` and either calls ``register_effect(cls)``
itself or leaves it to discovery: every non-abstract `Effect` subclass defined in the module
(not imported into it) whose name does not start with '_' is registered. docs/workbench.md
shows a complete example.
"""
from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import inspect
from pathlib import Path
import sys
from types import ModuleType, TracebackType
from typing import Callable, Iterable, List, Literal, Optional, Type, TYPE_CHECKING

if TYPE_CHECKING:
    from .effects import Effect

ENTRY_POINT_GROUP = 'sma_actuator.effects'


class PluginError(ValueError):
    """A plug-in cannot be loaded or registered; the message names it."""


def load_plugins(specs: Optional[Iterable[str]]) -> List[str]:
    """
    Load each --plugin spec (file path or module name); return the names of effects added.

    A plug-in may not replace an effect already in the catalog (same name, other class):
    that raises `PluginError` and the catalog is restored.
    """
    added = []
    for spec in specs or ():
        with guarded_catalog(spec):
            module = import_plugin(spec)
            added += register_module_effects(module, spec)
    return added


class guarded_catalog:
    """Context manager: undo catalog entries that replace an existing effect, then raise."""

    def __init__(self, origin: str):
        self.origin = origin

    def __enter__(self) -> guarded_catalog:
        """Remember the catalog as it is."""
        from .effects import CATALOG
        self.before = dict(CATALOG)
        return self

    def __exit__(self, exc_type: Optional[Type[BaseException]], exc: Optional[BaseException],
                 tb: Optional[TracebackType]) -> Literal[False]:
        """Restore replaced entries; raise `PluginError` for them if nothing else is raised."""
        from .effects import CATALOG
        clashes = [name for name, effect in self.before.items()
                   if type(CATALOG.get(name)) is not type(effect)]
        CATALOG.update({name: self.before[name] for name in clashes})
        if clashes and exc_type is None:
            raise PluginError(f'plugin {self.origin}: effect name(s) {", ".join(clashes)} '
                              'already taken by the catalog; choose another name')
        return False


def is_file_spec(spec: str) -> bool:
    """Return True if a --plugin spec names a Python file (else it is a module name)."""
    return spec.endswith('.py') or Path(spec).exists()


def import_plugin(spec: str) -> ModuleType:
    """Import a plug-in given as a .py path or a module name; errors name the plug-in."""
    path = Path(spec)
    try:
        if is_file_spec(spec):
            return _import_file(path)
        return importlib.import_module(spec)
    except PluginError:
        raise
    except ModuleNotFoundError as err:
        if err.name and spec.startswith(err.name):
            raise PluginError(f'plugin {spec}: no such file or module') from None
        raise PluginError(f'plugin {spec}: import failed: {err}') from None
    except SyntaxError as err:
        raise PluginError(f'plugin {spec}: syntax error at line {err.lineno}: {err.msg}') \
            from None
    except Exception as err:  # noqa: BLE001 - a user's module may raise anything on import
        raise PluginError(f'plugin {spec}: import failed: {type(err).__name__}: {err}') \
            from None


def _import_file(path: Path) -> ModuleType:
    """Import a .py file under a name unique to its path (imported once per process)."""
    if not path.is_file():
        raise PluginError(f'plugin {path}: no such file')
    name = f'sma_actuator_plugin_{path.stem}_{abs(hash(str(path.resolve()))):x}'
    if name in sys.modules:
        return sys.modules[name]
    module_spec = importlib.util.spec_from_file_location(name, path)
    if module_spec is None or module_spec.loader is None:
        raise PluginError(f'plugin {path}: cannot be loaded as a Python module')
    module = importlib.util.module_from_spec(module_spec)
    sys.modules[name] = module
    try:
        module_spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def effect_classes(module: ModuleType) -> List[Type[Effect]]:
    """Return the non-abstract public `Effect` subclasses defined in `module` itself."""
    from .effects import Effect
    return [obj for obj in vars(module).values()
            if inspect.isclass(obj) and issubclass(obj, Effect) and obj is not Effect
            and obj.__module__ == module.__name__ and not obj.__name__.startswith('_')
            and not inspect.isabstract(obj)]


def is_registered(cls: Type[Effect]) -> bool:
    """Return True if an instance of exactly `cls` is in the catalog."""
    from .effects import CATALOG
    return any(type(e) is cls for e in CATALOG.values())


def register_class(cls: Type[Effect], origin: str) -> str:
    """Call register_effect(cls) unless it is registered already; return the effect name."""
    from .effects import CATALOG, register_effect
    if not is_registered(cls):
        try:
            register_effect(cls)
        except (TypeError, ValueError) as err:
            raise PluginError(f'plugin {origin}: cannot register {cls.__name__}: {err}') \
                from None
    return next(name for name, e in CATALOG.items() if type(e) is cls)


def register_module_effects(module: ModuleType, origin: str) -> List[str]:
    """Register the module's effects (discovery by subclass scan); error if it has none."""
    classes = effect_classes(module)
    if not classes:
        raise PluginError(f'plugin {origin}: defines no subclass of '
                          'sma_actuator.workbench.effects.Effect')
    return [register_class(cls, origin) for cls in classes]


def load_entry_points(warn: Optional[Callable[[str], None]] = None) -> List[str]:
    """
    Register effects from the `sma_actuator.effects` entry-point group.

    A broken entry point does not stop the workbench: `warn(message)` is called (default:
    a line on stderr) and the others still load. Returns the names of effects added.
    """
    warn = warn or (lambda msg: print(f'sma-model: warning: {msg}', file=sys.stderr))
    added = []
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        origin = f'entry point {ep.name} ({ep.value})'
        try:
            with guarded_catalog(origin):
                added += _load_entry_point(ep, origin)
        except Exception as err:  # noqa: BLE001 - report and keep going
            warn(str(err) if isinstance(err, PluginError)
                 else f'plugin {origin}: {type(err).__name__}: {err}')
    return added


def _load_entry_point(ep: importlib.metadata.EntryPoint, origin: str) -> List[str]:
    """Register the effects of one entry point (an Effect subclass or a module)."""
    obj = ep.load()
    if inspect.ismodule(obj):
        return register_module_effects(obj, origin)
    from .effects import Effect
    if not (inspect.isclass(obj) and issubclass(obj, Effect)):
        raise PluginError(f'plugin {origin}: is neither a module nor an Effect subclass')
    return [register_class(obj, origin)]
