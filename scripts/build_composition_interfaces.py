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
Generate the Python layer of composition_interfaces into this interpreter's site-packages.

`launch_ros` imports `composition_interfaces.srv` at import time; the package is not on
PyPI. This runs rosidl_generator_py (from the ros-rosidl-* wheels in the venv) over the
vendored .srv files (ros2/rcl_interfaces, Jazzy) and installs the generated message classes.
The C type support is not compiled: the classes import and construct, but a LoadNode
service call (composable nodes, which sma_actuator does not use) would fail.

Usage: python scripts/build_composition_interfaces.py SRC_DIR
(SRC_DIR: ../shared/vendor/ros2-launch-jazzy/composition_interfaces from the repo root).
"""
import os
from pathlib import Path
import shutil
import sys
import sysconfig
import tempfile


def main(argv=None):
    """Generate and install; return the exit code."""
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1 or not (Path(argv[0]) / 'srv').is_dir():
        print('usage: build_composition_interfaces.py SRC_DIR (with srv/*.srv)', file=sys.stderr)
        return 2
    src = Path(argv[0]).resolve()
    prefix = Path(sys.prefix)
    # the generators find their templates and the dependency .idl files on the ament index
    os.environ['AMENT_PREFIX_PATH'] = os.pathsep.join(
        p for p in (str(prefix), os.environ.get('AMENT_PREFIX_PATH', '')) if p)
    from rosidl_generator_py.cli import GeneratePython

    srvs = sorted(str(p.relative_to(src)) for p in (src / 'srv').glob('*.srv'))
    target = Path(sysconfig.get_paths()['purelib']) / 'composition_interfaces'
    with tempfile.TemporaryDirectory() as tmp:
        cwd = os.getcwd()
        os.chdir(src)   # interface paths are relative to the package directory
        try:
            generated = GeneratePython('py').generate(
                'composition_interfaces', srvs, [str(prefix / 'share')], Path(tmp) / 'gen')
        finally:
            os.chdir(cwd)
        py_files = [Path(f) for f in generated if f.endswith('.py')]
        shutil.rmtree(target, ignore_errors=True)
        (target / 'srv').mkdir(parents=True)
        (target / '__init__.py').write_text('')
        for f in py_files + [Path(tmp) / 'gen' / 'srv' / '__init__.py']:
            shutil.copy2(f, target / 'srv' / f.name)
    print(f'composition_interfaces: {len(srvs)} services (Python layer) -> {target}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
