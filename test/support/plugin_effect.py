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

"""A plug-in effect file the tests load: a PWM dead time (docs/workbench.md, "Plug-ins")."""

DEAD_TIME_PLUGIN = '''
import numpy as np
from sma_actuator.workbench.effects import Effect


class PwmDeadTime(Effect):
    """PWM dead time: the driver needs a minimum pulse, so duties below d0 heat nothing
    and the rest is rescaled, d' = max(d - d0, 0) / (1 - d0)."""
    name = 'pwm_dead_time'
    parameters = {'dead_duty': (0.0, 0.4, 0.05)}
    neutral = {'dead_duty': 0.0}
    signature = 'model heats too much at small duties'

    def transform_inputs(self, duty_a, duty_b, ambient, values):
        d0 = values['dead_duty']
        return (np.clip((duty_a - d0) / (1 - d0), 0, 1),
                np.clip((duty_b - d0) / (1 - d0), 0, 1), ambient)
'''


def install_entry_point(site, module, entry_points):
    """
    Make `site` hold DEAD_TIME_PLUGIN as `module` and a distribution that exposes it.

    `entry_points` maps an entry-point name to an object of `module`, in the group the
    workbench reads (`plugins.ENTRY_POINT_GROUP`); with `site` on sys.path the effect is
    installed as `pip install` would install it.
    """
    from sma_actuator.workbench.plugins import ENTRY_POINT_GROUP
    site.mkdir(parents=True, exist_ok=True)
    (site / f'{module}.py').write_text(DEAD_TIME_PLUGIN)
    info = site / f'{module}-0.1.dist-info'
    info.mkdir()
    (info / 'METADATA').write_text(f'Metadata-Version: 2.1\nName: {module}\nVersion: 0.1\n')
    lines = [f'{name} = {module}:{attr}' for name, attr in entry_points.items()]
    (info / 'entry_points.txt').write_text('\n'.join([f'[{ENTRY_POINT_GROUP}]', *lines]) + '\n')
    return site
