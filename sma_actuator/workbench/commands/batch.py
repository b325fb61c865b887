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

"""`sma-model batch`: fit, compare and diagnose every record on a Dask cluster."""
from __future__ import annotations

import argparse
from pathlib import Path
import sys
from typing import Any

from .steps import (check_effect_names, column_renames, EXIT_INTERRUPTED, note, print_json,
                    read_model_spec, setup_effects, UsageError)
from ..remaining import PROG


def cmd_batch(args: argparse.Namespace) -> int:
    """Run `sma-model batch`: fit, compare and diagnose every record on a Dask cluster."""
    from ..batch import (BatchOptions, BatchProgress, find_records, run_batch, start_client,
                         worker_plugins)
    from ..fleet import write_index, write_table
    catalog = setup_effects(args)
    spec = read_model_spec(args.model, catalog) if args.model else {'effects': []}
    if args.candidates:
        check_effect_names(args.candidates, catalog, '--candidates')
    column_renames(args)
    paths = find_records(args.data)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UsageError(f'--out {out}: exists and is not a directory')
    if any(out.resolve() == p for p in paths):
        raise UsageError(f'--out {out} is one of the records; choose another path')
    out.mkdir(parents=True, exist_ok=True)
    from ...core.model_file import is_fitted, json_safe
    options = BatchOptions(effects=tuple(spec['effects']), kind=args.kind or spec.get('kind'),
                           candidates=tuple(args.candidates) if args.candidates else None,
                           rounds=args.rounds, rate_hz=args.rate, max_rate_hz=args.max_rate,
                           reports=not args.no_reports,
                           reference=json_safe(spec) if is_fitted(spec) else None,
                           position_unit=args.position_unit,
                           default_unit=spec.get('position_unit') or 'rad',
                           layout=args.layout, columns=tuple(args.column),
                           keep_glitches=args.keep_glitches,
                           plugins=worker_plugins(args.plugin))
    note(args, f'batch: {len(paths)} records -> {out}')
    results = []
    client = start_client(args.scheduler, args.workers)
    try:
        run_batch(paths, out, options, client, force=args.force,
                  progress=BatchProgress(len(paths)), results=results)
    except KeyboardInterrupt:
        write_table(out, results)
        write_index(out, results)
        print(f'{PROG}: interrupted; {out / "batch.parquet"} holds the {len(results)} of '
              f'{len(paths)} records finished so far (rerun to continue)', file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        _close_client(client)
    table, _ = write_table(out, results)
    index = write_index(out, results)
    failed = sum(1 for r in results if r['error'])
    if args.json:
        print_json({'out': str(out), 'records': len(results), 'errors': failed,
                    'table': str(table), 'index': str(index),
                    'named': {Path(r['record']).name: r['effects_added'] for r in results}})
    else:
        print(f'{len(results)} records, {failed} errors; table {table}; index {index}')
    return 0


def _close_client(client: Any) -> None:
    """Close the client and, if it started one, its local cluster."""
    cluster = client.cluster
    client.close()
    if cluster is not None:
        cluster.close()
