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

"""`sma-model effects`: list the effect catalog, plug-ins included."""
from __future__ import annotations

import argparse

from .steps import print_json, setup_effects


def cmd_effects(args: argparse.Namespace) -> int:
    """Run `sma-model effects`: list the catalog (plug-ins too): parameters, signature, physics."""
    catalog = setup_effects(args)
    doc = [{'effect': name, 'parameters': {k: list(v[:2]) for k, v in e.parameters.items()},
            'needs_dynamic': bool(e.needs_dynamic), 'signature': e.signature, 'physics': e.doc}
           for name, e in catalog.items()]
    if args.json:
        print_json(doc)
        return 0
    for d in doc:
        bounds = ', '.join(f'{k} in [{lo:g}, {hi:g}]' for k, (lo, hi) in d['parameters'].items())
        print(f'{d["effect"]}: {bounds or "no free parameter"}')
        print(f'    physics:   {d["physics"]}')
        print(f'    signature: {d["signature"]}')
    return 0
