"""The LiDAR stream decoder against garbage: revolutions are never merged, pending
samples stay bounded, and noise is never handed on as a revolution."""

from __future__ import annotations

import random

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.runtime.devices.rplidar_codec import ScanDecoder, encode_sample

_BASE_Q2 = 4000


def _revolution(k: int, n: int = 360) -> bytes:
    """Revolution ``k``: n samples 360/n° apart; its distances say which revolution it is."""
    step = 360 * 64 // n
    return b"".join(encode_sample(j == 0, 10, j * step, _BASE_Q2 + k) for j in range(n))


def _sources(rev) -> set[int]:
    """The real revolutions whose samples ``rev`` holds (garbage strays have other distances)."""
    q2 = np.round(rev.distance_mm * 4).astype(int) - _BASE_Q2
    exact_degree = np.isclose(rev.angle_deg, np.round(rev.angle_deg))
    return set(q2[exact_degree & (q2 >= 0) & (q2 < 10_000)].tolist())


def _check_no_merge(revs, n: int = 360) -> None:
    for rev in revs:
        src = _sources(rev)
        assert len(src) == 1, f"one frame holds samples of revolutions {sorted(src)}"
        assert len(rev) <= n + 8


def _stream_with_bursts(rng: random.Random, n_rev: int, max_burst: int) -> bytes:
    out = bytearray()
    for k in range(n_rev):
        out += _revolution(k)
        out += bytes(rng.randrange(256) for _ in range(rng.randint(0, max_burst)))
    return bytes(out + _revolution(n_rev)[:10])


@pytest.mark.parametrize("max_burst", [16, 512, 2000])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_garbage_bursts_between_revolutions_never_merge_two(seed, max_burst):
    stream = _stream_with_bursts(random.Random(seed), 60, max_burst)
    d = ScanDecoder()
    revs = d.feed(stream)
    _check_no_merge(revs)
    # and most real revolutions get through (a burst may spoil the one after it)
    assert len(revs) >= 50, (len(revs), d.rejected_revolutions)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.binary(max_size=600), min_size=3, max_size=8), st.lists(st.integers(1, 400), max_size=20))
def test_any_garbage_between_revolutions_and_any_chunking_never_merges(bursts, cuts):
    stream = b"".join(_revolution(k) + g for k, g in enumerate(bursts)) + _revolution(len(bursts))[:10]
    d = ScanDecoder()
    revs = []
    pos = 0
    for c in cuts:
        revs += d.feed(stream[pos : pos + c])
        pos += c
    revs += d.feed(stream[pos:])
    _check_no_merge(revs)


def test_a_lost_start_sample_splits_rather_than_merges():
    # the flagged first sample of revolution 1 is eaten by garbage
    stream = _revolution(0) + b"\x00" * 7 + _revolution(1)[5:] + _revolution(2) + _revolution(3)[:10]
    revs = ScanDecoder().feed(stream)
    _check_no_merge(revs)
    assert [_sources(r) for r in revs] == [{0}, {1}, {2}]


def test_half_a_revolution_lost_in_garbage_is_not_glued_to_the_next():
    half = _revolution(0)[: 5 * 170]
    stream = _revolution(9) + half + bytes(range(256)) * 3 + _revolution(1) + _revolution(2)[:10]
    d = ScanDecoder()
    revs = d.feed(stream)
    _check_no_merge(revs)
    assert [_sources(r) for r in revs] == [{9}, {1}]
    assert d.rejected_revolutions >= 1


@pytest.mark.parametrize("fill", [0xA5, 0x3D, 0xFF])
def test_pending_samples_stay_bounded_on_a_stream_that_never_wraps(fill):
    d = ScanDecoder()
    chunk = bytes([fill]) * 4096
    peak = 0
    for _ in range(256):  # 1 MiB
        assert d.feed(chunk) == []
        peak = max(peak, d.pending_samples)
    assert peak <= d.max_samples


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_pure_noise_yields_no_revolution(seed):
    rng = np.random.default_rng(seed)
    noise = rng.integers(0, 256, 1 << 20, dtype=np.uint8).tobytes()  # 1 MiB
    d = ScanDecoder()
    revs = [r for i in range(0, len(noise), 4096) for r in d.feed(noise[i : i + 4096])]
    assert revs == []
    assert d.pending_samples <= d.max_samples


def test_real_revolutions_after_noise_are_decoded():
    rng = np.random.default_rng(4)
    noise = rng.integers(0, 256, 64 * 1024, dtype=np.uint8).tobytes()
    d = ScanDecoder()
    revs = d.feed(noise + b"".join(_revolution(k) for k in range(5)) + _revolution(5)[:10])
    # the first one may be spoilt by a stray left over from the noise
    assert [_sources(r) for r in revs][-4:] == [{1}, {2}, {3}, {4}]


def test_a_revolution_must_look_like_one():
    d = ScanDecoder()
    # 200 samples over the last 100° before the wrap: enough samples, too little circle
    part = b"".join(encode_sample(j == 0, 10, 260 * 64 + j * 32, 4000) for j in range(200))
    assert d.feed(part + _revolution(0)[:10]) == []
    assert d.rejected_revolutions == 1
    # a full circle with too few samples
    sparse = ScanDecoder(min_samples=50)
    few = b"".join(encode_sample(j == 0, 10, j * 9 * 64, 4000) for j in range(40))
    assert sparse.feed(few + few + few[:10]) == []
    with pytest.raises(ValueError):
        ScanDecoder(min_samples=0)
