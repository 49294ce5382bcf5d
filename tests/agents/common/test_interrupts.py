"""Stop signals while learning raise KeyboardInterrupt, but never in the middle of a write that must stay whole:
there they wait for the write to end."""

from __future__ import annotations

import os
import signal

import pytest
import torch

from agents.common.interrupts import stop_signals_deferred, stop_signals_interrupt


def test_a_stop_while_learning_raises_keyboard_interrupt() -> None:
    with pytest.raises(KeyboardInterrupt, match="SIGTERM received"), stop_signals_interrupt():
        os.kill(os.getpid(), signal.SIGTERM)
        signal.sigtimedwait([], 0)  # let the handler run


def test_a_stop_during_a_save_waits_until_the_file_is_whole(tmp_path) -> None:
    path = tmp_path / "weights.pt"
    reached_the_end = False
    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt, match="SIGTERM received"), stop_signals_interrupt():
        with stop_signals_deferred():
            os.kill(os.getpid(), signal.SIGTERM)
            torch.save({"w": torch.zeros(1000)}, path)  # would be cut in two, and torch's error hide the stop
            reached_the_end = True
    assert reached_the_end
    assert torch.load(path)["w"].shape == (1000,)
    assert signal.getsignal(signal.SIGTERM) is before  # outside both blocks, the handler from before


def test_an_ignored_stop_stays_ignored_after_a_deferred_write() -> None:
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with stop_signals_deferred():
            os.kill(os.getpid(), signal.SIGINT)
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)
