"""The training record (``runs/<name>/<name>.json``): the run's sessions, its totals and the selected policy.

A session is written into the record when it starts and updated at each checkpoint and when it ends, so a
session stopped outright (``kill -9``, a lost machine, a disk too full to take even the record) still shows:
its ``ended`` stays null and its status ``"running"``, until the next session of the run marks it
``"killed"``. Each session keeps the command that started it, every option included.

``total_timesteps`` and ``selected`` describe the policy file written at a session's end, so they only change
then (:meth:`agents.training.outputs.RunFiles.trained_steps` decides from them whether a seed is finished).
"""

from __future__ import annotations

import json
import time
from collections.abc import Mapping
from datetime import datetime, timezone
from typing import NotRequired, TypedDict, cast

from agents.common.folders import write_text_atomically
from agents.common.machine import available_cores, code_version, cpu_model
from agents.training.outputs import RunFiles
from agents.training.train_config import TrainConfig, init_source
from flownav_env.rendering import gl_renderer_name
from flownav_env.settings import ENV_ESTIMATOR_DEFAULTS

# A session's status: running until it ends as finished, interrupted (Ctrl-C, SIGTERM) or failed (an error);
# one that never wrote its end is marked killed by the next session.
RUNNING, FINISHED, INTERRUPTED, FAILED, KILLED = "running", "finished", "interrupted", "failed", "killed"


class SessionFacts(TypedDict):
    """What a session runs with (:func:`session_facts`)."""

    total_timesteps_asked: int
    max_minutes: float
    cpu: str
    cores: int
    n_envs: int
    env_workers: str
    code: str
    env_estimator_defaults: dict[str, object]
    gl_renderer: str


class InitSummary(TypedDict):
    """The earlier stage a run started from (:func:`init_summary`); its steps and minutes are None when it has
    no record."""

    path: str
    timesteps: int | None
    wall_minutes: float | None


class Session(SessionFacts):
    """A session's entry in the record: its facts, when and how it ran and how it ended (``error``: why a failed
    one failed; ``imitation``: the teacher start's summary). Records written by earlier code may lack some facts."""

    started: str
    ended: str | None
    status: str
    command: str
    steps_at_start: int
    steps_this_session: int
    wall_minutes: float
    steps_per_second: float
    interrupted: bool | None
    error: NotRequired[str]
    imitation: NotRequired[Mapping[str, object]]


class TrainingRecord(TypedDict):
    """The run's record: its sessions, the last command, the totals and, once a session wrote the run's policy,
    its steps and how it was selected."""

    sessions: list[Session]
    command: NotRequired[str]
    total_timesteps: NotRequired[int]
    selected: NotRequired[str]
    total_wall_minutes: NotRequired[float]
    init_from: NotRequired[InitSummary]
    total_wall_minutes_with_init: NotRequired[float]


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def session_facts(config: TrainConfig, in_process_envs: bool) -> SessionFacts:
    """What a session runs with, for its entry in the record: the budget, the machine and the code."""
    return {
        "total_timesteps_asked": config.total_timesteps,
        "max_minutes": config.max_minutes,
        "cpu": cpu_model(),
        "cores": available_cores(),
        "n_envs": config.n_envs,
        "env_workers": "in process" if in_process_envs or config.n_envs == 1 else "one subprocess per env",
        # What the policy saw depends on these as much as on the config: record them per session.
        "code": code_version(),
        "env_estimator_defaults": dict(ENV_ESTIMATOR_DEFAULTS),
        "gl_renderer": gl_renderer_name(),
    }


def init_summary(config: TrainConfig) -> InitSummary | None:
    """For the record: the earlier stage a run started from (``init_from``), its steps and training minutes
    (from the record beside it, when there is one), so a curriculum's cost per seed adds up."""
    source = init_source(config)
    if source is None:
        return None
    record = source.with_suffix(".json")
    earlier = json.loads(record.read_text()) if record.is_file() else {}
    return {
        "path": str(source),
        "timesteps": earlier.get("total_timesteps"),
        "wall_minutes": earlier.get("total_wall_minutes"),
    }


def read_record(files: RunFiles) -> TrainingRecord | None:
    """The run's record, or None when there is none or it does not read as a record (a warning says so)."""
    if not files.record.is_file():
        return None
    try:
        record = json.loads(files.record.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        print(f"warning: {files.record} is unreadable, starting a new record: {error}")
        return None
    if not isinstance(record, dict) or not isinstance(record.get("sessions"), list):
        print(f"warning: {files.record} holds no list of sessions, starting a new record")
        return None
    return cast(TrainingRecord, record)  # written by SessionRecord; its sessions are not checked one by one


def last_session(files: RunFiles) -> Session | None:
    """The newest session in the run's record; None when there is none."""
    record = read_record(files)
    return record["sessions"][-1] if record and record["sessions"] else None


def interrupted_at(files: RunFiles) -> int | None:
    """The step count at which Ctrl-C or SIGTERM stopped the run's last session (and its checkpoint was saved),
    or None when that session was not interrupted."""
    session = last_session(files)
    if session is None or session.get("status") != INTERRUPTED:
        return None
    return int(session["steps_at_start"]) + int(session["steps_this_session"])


class SessionRecord:
    """This session's entry in the run's record, written at once and kept up to date.

    Args:
        files: the run.
        facts: what the session is run with (machine, code, config values), stored in its entry.
        command: the command line that started the session.
        keep_earlier: continue the record of earlier sessions (a resumed run) instead of starting anew.
        steps_at_start: the model's step count when the session starts.
        init: the earlier stage the run started from (:func:`init_summary`), or None.

    Raises:
        OSError: the record could not be written; it names the file.
    """

    def __init__(
        self,
        files: RunFiles,
        facts: SessionFacts,
        *,
        command: str,
        keep_earlier: bool,
        steps_at_start: int,
        init: InitSummary | None = None,
    ) -> None:
        self.files = files
        self.init = init
        self.steps_at_start = int(steps_at_start)
        self.started = time.perf_counter()
        self.record: TrainingRecord = (read_record(files) if keep_earlier else None) or {"sessions": []}
        for earlier in self.record["sessions"]:
            if earlier.get("status") == RUNNING:  # it never wrote its end: killed outright
                earlier.update({"status": KILLED, "interrupted": True})
        self.session: Session = {
            "started": _now(),
            "ended": None,
            "status": RUNNING,
            "command": command,
            "steps_at_start": self.steps_at_start,
            "steps_this_session": 0,
            "wall_minutes": 0.0,
            "steps_per_second": 0.0,
            "interrupted": None,
            **facts,
        }
        self.record["sessions"].append(self.session)
        self.record["command"] = command
        self.write()

    def restart_clock(self) -> None:
        """Count the session's minutes from now: the time learning starts, after the envs and model are built."""
        self.started = time.perf_counter()

    @property
    def wall_minutes(self) -> float:
        """Minutes since the clock started."""
        return (time.perf_counter() - self.started) / 60.0

    def progress(self, steps: int) -> None:
        """Record the steps (the model's count, ``steps``) and minutes so far; at each checkpoint.

        Raises:
            OSError: the record could not be written; it names the file.
        """
        minutes = self.wall_minutes
        done = int(steps) - self.steps_at_start
        self.session.update(
            {
                "steps_this_session": done,
                "wall_minutes": round(minutes, 1),
                "steps_per_second": round(done / max(minutes * 60, 1e-9), 1),
            }
        )
        self.write()

    def end(self, status: str, steps: int, *, selected: str | None = None, error: str | None = None) -> None:
        """Record the session's end: its ``status``, its steps and, when it wrote the run's policy, the policy's
        steps and how it was ``selected``; ``error`` says why a failed session failed.

        Raises:
            OSError: the record could not be written; it names the file.
        """
        self.session.update({"ended": _now(), "status": status, "interrupted": status != FINISHED})
        if error is not None:
            self.session["error"] = error
        if selected is not None:
            self.record["total_timesteps"] = int(steps)
            self.record["selected"] = selected
        self.progress(steps)

    def write(self) -> None:
        """Write the record with its totals over all sessions, atomically.

        Raises:
            OSError: the record could not be written; it names the file.
        """
        record = self.record
        record["total_wall_minutes"] = round(sum(s.get("wall_minutes") or 0 for s in record["sessions"]), 1)
        if self.init is not None:
            record["init_from"] = self.init
            record["total_wall_minutes_with_init"] = round(
                record["total_wall_minutes"] + (self.init["wall_minutes"] or 0), 1
            )
        write_text_atomically(self.files.record, json.dumps(record, indent=2))
