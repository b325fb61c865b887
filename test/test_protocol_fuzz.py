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
Fuzz test of the frame decoder: 100,000 random and mutated inputs.

Checks, for every input: no exception escapes the decoder; no false frame is accepted
(random bytes yield nothing, mutated streams yield only frames that were really sent);
and every frame the mutations did not touch is still decoded (resynchronisation).
"""
import random
import time

import pytest
from sma_actuator.hardware import protocol as p

N_RANDOM = 50_000
N_MUTATED = 50_000


def _random_message(rng):
    cls = rng.choice(list(p.MESSAGES.values()))
    limits = {'B': 0xFF, 'H': 0xFFFF, 'I': 0xFFFFFFFF}
    return cls(*(rng.randint(0, limits[c]) for c in cls.FORMAT.format[1:]))


def _mutate(rng, piece: bytes) -> bytes:
    data = bytearray(piece)
    if not data:   # an earlier mutation truncated the whole piece
        return bytes((rng.randrange(256),))
    where = rng.randrange(len(data))
    op = rng.randrange(7)
    if op == 0:
        data[where] ^= 1 << rng.randrange(8)          # bit flip
    elif op == 1:
        data[where] = rng.randrange(256)              # byte replaced
    elif op == 2:
        data.insert(where, rng.choice((0, rng.randrange(256))))  # byte inserted
    elif op == 3:
        del data[where]                               # byte lost
    elif op == 4:
        del data[where:]                              # truncated (delimiter lost)
    elif op == 5:
        data[where:where] = data[rng.randrange(len(data)):][:rng.randrange(1, 8)]  # repeated run
    else:
        other = rng.randrange(len(data))              # two bytes swapped
        data[where], data[other] = data[other], data[where]
    return bytes(data)


def _mutated_case(rng, pool):
    """Return a stream of sent frames, some mutated; returns (stream, sent, must_decode)."""
    picks = rng.sample(pool, rng.randint(1, 4))
    pieces = [wire for _, wire in picks]
    for _ in range(rng.randint(1, 3)):
        i = rng.randrange(len(pieces))
        pieces[i] = _mutate(rng, pieces[i])
    if rng.random() < 0.1:   # line noise before the first frame (no delimiter)
        pieces.insert(0, bytes(rng.randrange(1, 256) for _ in range(rng.randint(1, 6))))
        picks.insert(0, None)
    must = [pick for i, pick in enumerate(picks)
            if pick is not None and pieces[i] == pick[1]
            and (i == 0 or pieces[i - 1].endswith(b'\x00'))]
    return b''.join(pieces), [pick[0] for pick in picks if pick is not None], [m[0] for m in must]


def _is_subsequence(needle, haystack):
    it = iter(haystack)
    return all(any(x == y for y in it) for x in needle)


def run_fuzz(seed, n_random, n_mutated):
    """Run the fuzz cases; returns a list of failure descriptions (empty = all passed)."""
    rng = random.Random(seed)
    pool = []
    for _ in range(3000):
        seq, msg = rng.randrange(256), _random_message(rng)
        pool.append(((seq, msg), msg.encode(seq)))
    failures = []
    specials = [b'', b'\x00' * 100, b'\xff' * 300, bytes(range(256)) * 2]
    for i in range(n_random):
        data = specials[i] if i < len(specials) else rng.randbytes(rng.randrange(1, 90))
        if rng.random() < 0.5:   # many short zero-separated chunks exercise every check
            data = bytes(b if rng.random() > 0.15 else 0 for b in data)
        got = p.MessageStream().feed(data)
        if got:
            failures.append(f'random input {data.hex()} accepted {got}')
    for _ in range(n_mutated):
        data, sent, must = _mutated_case(rng, pool)
        got = p.MessageStream().feed(data)
        if not _is_subsequence(got, sent):
            failures.append(f'false frame: {data.hex()} gave {got}, sent {sent}')
        elif not _is_subsequence(must, got):
            failures.append(f'lost intact frame: {data.hex()} gave {got}, intact {must}')
    return failures


@pytest.mark.slow
def test_fuzz_100k_random_and_mutated_inputs():
    start = time.perf_counter()
    failures = run_fuzz(seed=4, n_random=N_RANDOM, n_mutated=N_MUTATED)
    print(f'{N_RANDOM + N_MUTATED} fuzz inputs in {time.perf_counter() - start:.2f} s')
    assert not failures, f'{len(failures)} failures, first: {failures[:3]}'


def test_fuzz_harness_catches_a_decoder_without_crc(monkeypatch):
    # The same harness must notice false frames when the CRC check is missing.
    def decode_chunk_without_crc(chunk):
        try:
            payload = p.cobs_decode(chunk)
        except p.ProtocolError:
            return p.FrameError('cobs')
        if len(payload) < p.MIN_PAYLOAD:
            return p.FrameError('short')
        return p.Frame(payload[0], payload[1], payload[2:-4])
    monkeypatch.setattr(p, 'decode_chunk', decode_chunk_without_crc)
    failures = run_fuzz(seed=4, n_random=0, n_mutated=2000)
    assert any(f.startswith('false frame') for f in failures)
