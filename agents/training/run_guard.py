"""Everything that can end a training session early, handled in one place: ``with run_guard(...) as guard:``.

Inside the block, :func:`agents.training.ppo.train` builds the model, starts the session's record, and runs the
two steps that take long through the guard: the teacher start (:meth:`RunGuard.teacher_start`) and learning
(:meth:`RunGuard.learn`). What the guard does when a session ends early:

- Ctrl-C or SIGTERM (both raise ``KeyboardInterrupt`` while those steps run, and only then: a seed still
  building its envs simply ends): while learning, the model is checkpointed, the session's status becomes
  ``interrupted`` and the run's outputs are still written; during the teacher start, nothing of which is
  checkpointed, the session is recorded as interrupted at step 0 and the interrupt goes on to the caller.
- A failure while learning (a full disk, a NaN that torch refuses): the record says why first (the smallest
  write), then the model is checkpointed where the disk still allows, and an ``OSError`` is named after its
  file (the run's folder when the writer did not say). Neither a second failure hides the first.
- Any other failure once the session's record is started (writing the outputs, the teacher start): the session
  is recorded as failed, with the error, where the disk still takes it.
- Whatever happens, the env workers are closed on leaving the block: they ignore stop signals, so one left
  open would keep the process from exiting.

The time cap is not a failure: :class:`agents.training.callbacks.WallClockBudget` ends learning as finished.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager, suppress
from dataclasses import dataclass

from stable_baselines3.common.callbacks import CallbackList, ProgressBarCallback
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.vec_env import VecEnv

from agents.common.folders import named_os_error
from agents.common.interrupts import stop_signals_interrupt
from agents.training.envs import close_quietly
from agents.training.outputs import RunFiles
from agents.training.run_record import FAILED, FINISHED, INTERRUPTED, SessionRecord


@dataclass
class RunGuard:
    """One training session's guard: what it needs to end the session well (its record, the model and how to
    checkpoint it, once they exist) and how learning ended (:attr:`status`)."""

    files: RunFiles
    workers: tuple[VecEnv, ...]
    status: str = FINISHED
    model: OnPolicyAlgorithm | None = None
    record: SessionRecord | None = None
    checkpoint: Callable[[], None] | None = None
    # Whether the guard has recorded how the session ended (an interrupted teacher start, a failure while
    # learning), which a later failure must not overwrite.
    ended: bool = False

    def start(self, model: OnPolicyAlgorithm, record: SessionRecord, checkpoint: Callable[[], None]) -> None:
        """From here a session that ends early is recorded, and an interrupted one saves ``checkpoint``."""
        self.model, self.record, self.checkpoint = model, record, checkpoint

    @property
    def steps(self) -> int:
        return self.model.num_timesteps if self.model is not None else 0

    def teacher_start(self, imitate: Callable[[], Mapping[str, object]]) -> None:
        """Run the teacher start (``imitate`` returns its summary, which goes into the session's record);
        Ctrl-C or SIGTERM ends the session as interrupted and is raised on.

        Raises:
            KeyboardInterrupt: Ctrl-C or SIGTERM during the teacher start.
        """
        record = self._started()
        try:
            with stop_signals_interrupt():
                summary = imitate()
        except KeyboardInterrupt:
            # Nothing of a teacher start is checkpointed (it is minutes): resuming starts the run afresh.
            print("interrupted during the teacher start: the same command starts the run again")
            self.ended = True
            record.end(INTERRUPTED, 0)
            raise
        record.session["imitation"] = summary
        record.write()

    def learn(self, learn: Callable[[], object], callbacks: CallbackList) -> None:
        """Run ``learn`` and checkpoint the model, the resume point; Ctrl-C or SIGTERM ends learning early with
        a checkpoint and :attr:`status` :data:`INTERRUPTED`. A progress bar among ``callbacks`` is closed
        whatever happens, or its refresh thread goes on printing into whatever runs next.

        Raises:
            OSError: a write failed (full disk, file-size limit), naming the file (the run's folder when the
                writer did not say); the session is recorded as failed where the disk still allows.
        """
        record, checkpoint = self._started(), self.checkpoint or (lambda: None)
        try:
            with stop_signals_interrupt():
                learn()
        except KeyboardInterrupt:
            print(f"interrupted at {self.steps} steps: saving; --resume continues from here")
            checkpoint()
            self.status = INTERRUPTED
            return
        except BaseException as error:
            # The record goes first: it is the smallest write, and a checkpoint's failed save may leave no room
            # for it.
            self.ended = True
            with suppress(Exception):
                record.end(FAILED, self.steps, error=f"{type(error).__name__}: {error}")
            with suppress(Exception):
                checkpoint()
            if isinstance(error, OSError) and not isinstance(error, ConnectionError):
                raise named_os_error(error, self.files.run_dir) from None
            raise
        finally:
            for bar in callbacks.callbacks:
                if isinstance(bar, ProgressBarCallback) and hasattr(bar, "pbar"):
                    bar.pbar.close()  # idempotent: a finished session closed it already
        checkpoint()

    def end(self, selected: str) -> None:
        """Record the session's end with :attr:`status` and the policy written (how it was ``selected``)."""
        self._started().end(self.status, self.steps, selected=selected)

    def _started(self) -> SessionRecord:
        if self.record is None:
            raise RuntimeError("the session's record is not started: call RunGuard.start first")
        return self.record

    def _failed(self, error: BaseException) -> None:
        """Record a failure that ended the session, unless the session has ended already (an interrupted
        teacher start, a failure while learning): the record says why, where the disk still takes it."""
        if self.record is None or self.ended:
            return
        with suppress(Exception):
            self.record.end(FAILED, self.steps, error=f"{type(error).__name__}: {error}")


@contextmanager
def run_guard(files: RunFiles, *workers: VecEnv) -> Iterator[RunGuard]:
    """Guard one training session of the run ``files`` whose env workers are ``workers`` (see the module)."""
    guard = RunGuard(files, workers)
    try:
        yield guard
    except Exception as error:
        guard._failed(error)
        raise
    finally:
        for envs in workers:
            close_quietly(envs)
