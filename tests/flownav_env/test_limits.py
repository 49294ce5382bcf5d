"""The course-scaled time limit refuses a speed, frame rate or field length that is not a number."""

from __future__ import annotations

import numpy as np
import pytest

from flownav_env.limits import episode_step_limit


@pytest.mark.parametrize("value", ["fast", True, None])
def test_a_setting_the_limit_reads_must_be_a_number(value: object) -> None:
    with pytest.raises(ValueError, match=rf"^forward_speed must be a number, got {value!r}$"):
        episode_step_limit("FlowNav-v0", {"forward_speed": value})


def test_a_numpy_number_counts_as_a_number() -> None:
    assert (
        episode_step_limit("FlowNav-v0", {"forward_speed": np.float32(0.5), "frame_rate": np.int64(10)})
        == 800
    )
