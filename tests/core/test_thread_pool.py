"""each_on_threads: every item once, on the calling thread and the pool's, errors raised."""
import threading
import time

import pytest

from warp_st.core.thread_pool import each_on_threads


def test_each_item_is_called_once_on_both_threads():
    seen = []
    threads = set()

    def fn(item):
        time.sleep(0.002)  # long enough that both threads take items
        seen.append(item)
        threads.add(threading.get_ident())

    each_on_threads(fn, range(40), 2)
    assert sorted(seen) == list(range(40))
    assert threading.get_ident() in threads  # the calling thread works too
    assert len(threads) == 2


@pytest.mark.parametrize("n_threads", [1, 2])
def test_one_thread_or_one_item_runs_in_order_on_the_caller(n_threads):
    calls = []
    each_on_threads(lambda item: calls.append((item, threading.get_ident())), [7] if n_threads == 2 else [3, 1, 2],
                    n_threads)
    assert [item for item, _ in calls] == ([7] if n_threads == 2 else [3, 1, 2])
    assert {ident for _, ident in calls} == {threading.get_ident()}


@pytest.mark.parametrize("failing", [0, 5])
def test_the_first_error_is_raised_and_no_item_is_taken_after_it(failing):
    seen = []
    lock = threading.Lock()

    def fn(item):
        with lock:
            seen.append(item)
        if item == failing:
            raise ValueError(f"item {item}")
        time.sleep(0.002)

    with pytest.raises(ValueError, match=f"item {failing}"):
        each_on_threads(fn, range(200), 2)
    assert len(seen) < 200  # the threads stopped taking items
    assert len(seen) == len(set(seen))
