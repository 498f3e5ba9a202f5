"""Favoured scheduling for the real-time threads: per thread, inherited, restored."""

from __future__ import annotations

import os
import sys
import threading

import pytest

from clomp.runtime.realtime import NICENESS, favour_this_thread, favoured

linux_root = pytest.mark.skipif(not sys.platform.startswith("linux") or os.geteuid() != 0,
                                reason="raising a thread's priority needs Linux and the right to (root here)")


def _nice() -> int:
    return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())


def _nice_of_a_new_thread() -> int:
    seen: list[int] = []
    t = threading.Thread(target=lambda: seen.append(_nice()))
    t.start()
    t.join()
    return seen[0]


@linux_root
def test_the_block_runs_favoured_its_threads_inherit_and_the_thread_is_restored_after() -> None:
    before = _nice()
    outside: list[int] = []
    gate, done = threading.Event(), threading.Event()

    def bystander() -> None:  # started before: not favoured by another thread's block
        gate.wait(10)
        outside.append(_nice())
        done.set()

    t = threading.Thread(target=bystander)
    t.start()
    with favoured() as how:
        assert how == f"nice {NICENESS}" and _nice() == NICENESS
        assert _nice_of_a_new_thread() == NICENESS
        gate.set()
        assert done.wait(10)
    t.join()
    assert outside == [before]
    assert _nice() == before and _nice_of_a_new_thread() == before


@linux_root
def test_a_thread_already_more_favoured_is_left_as_it_is() -> None:
    with favoured(NICENESS - 2):
        assert favour_this_thread() == f"nice {NICENESS - 2}" and _nice() == NICENESS - 2


def test_without_the_right_nothing_changes_and_it_says_so() -> None:
    if os.geteuid() == 0:
        pytest.skip("root may raise priorities")
    before = _nice()
    with favoured() as how:
        assert how == "normal" and _nice() == before


@linux_root
def test_the_real_time_class_is_asked_for_only_when_told_and_is_inherited() -> None:
    seen: list[tuple[str, int, int]] = []

    def thread() -> None:
        how = favour_this_thread(realtime=True)
        child: list[int] = []
        t = threading.Thread(target=lambda: child.append(os.sched_getscheduler(0)))
        t.start()
        t.join()
        seen.append((how, os.sched_getscheduler(0), child[0]))

    t = threading.Thread(target=thread)  # a thread of its own: the class stays with it, and it ends
    t.start()
    t.join()
    assert seen == [("realtime", os.SCHED_RR, os.SCHED_RR)]
    assert os.sched_getscheduler(0) == os.SCHED_OTHER  # this thread was not touched
    with favoured() as how:
        assert how == f"nice {NICENESS}" and os.sched_getscheduler(0) == os.SCHED_OTHER
