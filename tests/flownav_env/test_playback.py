"""flownav_env.playback: file round trip, resampling, slerp, playback exactness and determinism, the sensor
error models it takes (motion) and refuses (depth), bad input."""

from __future__ import annotations

import numpy as np
import pytest

from flownav_env.playback import (
    CameraPath,
    PlaybackSettings,
    PlaybackWorld,
    label_world_points,
    load_path,
    path_from_poses,
    play_back,
    resample_by_distance,
    save_path,
)
from flownav_env.rotations import camera_rotation, rotation_from_vector, vector_from_rotation

SIZE = (48, 36)


def random_path(frames: int = 6, seed: int = 0) -> CameraPath:
    rng = np.random.default_rng(seed)
    rotations = np.array(
        [camera_rotation(0.1 * i, rotation_from_vector(rng.normal(0, 0.05, 3))) for i in range(frames)]
    )
    positions = np.column_stack(
        [np.arange(frames) * 0.1, rng.normal(0, 0.02, (frames, 2)) + np.array([0.0, 1.0])]
    )
    return path_from_poses(
        rotations, positions, 10.0, obstacles=[[3.0, 0.0], [4.0, 1.0]], materials=[0, 3], texture_seed=2
    )


def test_file_round_trip_is_exact(tmp_path) -> None:
    path = random_path()
    loaded = load_path(save_path(path, tmp_path / "path.npz"))
    for name in ("times", "positions", "quaternions", "obstacles", "materials"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(path, name))
    assert (loaded.frame_rate, loaded.texture_seed) == (path.frame_rate, path.texture_seed)
    assert (loaded.obstacle_radius, loaded.obstacle_height) == (path.obstacle_radius, path.obstacle_height)


def test_recorded_path_plays_back_at_the_recorded_poses_and_round_trips(tmp_path) -> None:
    path = load_path(save_path(random_path(), tmp_path / "path.npz"))
    world = PlaybackWorld(path, *SIZE)
    try:
        frames = list(play_back(path, world, PlaybackSettings()))
    finally:
        world.close()
    assert len(frames) == len(path)
    np.testing.assert_allclose([f.position for f in frames], path.positions, atol=1e-12)
    np.testing.assert_allclose([f.rotation for f in frames], path.rotations(), atol=1e-12)
    replayed = path_from_poses(
        np.array([f.rotation for f in frames]), np.array([f.position for f in frames]), path.frame_rate
    )
    again = load_path(save_path(replayed, tmp_path / "replayed.npz"))
    np.testing.assert_allclose(again.positions, path.positions, atol=1e-12)
    np.testing.assert_allclose(again.rotations(), path.rotations(), atol=1e-12)
    assert frames[0].image.shape == (SIZE[1], SIZE[0], 3)


def test_resampling_spaces_frames_by_distance_and_slerps_rotations() -> None:
    rotations = np.array([camera_rotation(0.0), camera_rotation(0.4)])
    path = path_from_poses(rotations, [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]], 10.0)
    resampled = resample_by_distance(path, 0.25)
    assert len(resampled) == 5
    np.testing.assert_allclose(resampled.positions[:, 0], [0.0, 0.25, 0.5, 0.75, 1.0], atol=1e-12)
    np.testing.assert_allclose(resampled.rotations()[2], camera_rotation(0.2), atol=1e-12)
    np.testing.assert_allclose(resampled.times, np.arange(5) / 10.0)
    assert len(resample_by_distance(path, 0.25, max_frames=3)) == 3
    # Resampling at the recorded spacing gives the recorded poses back.
    path = random_path()
    steps = np.linalg.norm(np.diff(path.positions, axis=0), axis=1)
    uniform = path.with_poses(
        path.times, np.cumsum(np.r_[0, np.full(5, 0.1)])[:, None] * [1, 0, 0], path.quaternions
    )
    again = resample_by_distance(uniform, 0.1)
    np.testing.assert_allclose(again.positions, uniform.positions, atol=1e-12)
    np.testing.assert_allclose(again.rotations(), uniform.rotations(), atol=1e-12)
    assert steps.min() > 0


def test_playback_is_deterministic_for_a_seed() -> None:
    path = random_path(frames=4)
    settings = PlaybackSettings(attitude_jitter_deg=1.0, rotation_error=0.05, translation_error=0.05, seed=7)
    world = PlaybackWorld(path, *SIZE)
    try:
        first = list(play_back(path, world, settings))
        second = list(play_back(path, world, settings))
        other = list(play_back(path, world, PlaybackSettings(attitude_jitter_deg=1.0, seed=8)))
    finally:
        world.close()
    for a, b in zip(first, second, strict=True):
        np.testing.assert_array_equal(a.image, b.image)
        np.testing.assert_array_equal(a.told_motion[0], b.told_motion[0])
        np.testing.assert_array_equal(a.told_motion[1], b.told_motion[1])
    assert not np.array_equal(first[1].rotation, other[1].rotation)


def test_labels_capsule_ground_and_sky() -> None:
    points = np.array([[3.5, 0.0, 1.0], [1.0, 2.0, 0.0], [np.nan, np.nan, np.nan]])
    np.testing.assert_array_equal(label_world_points(points, np.array([[4.0, 0.0]]), 0.5, 2.0), [0, -1, -2])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"brightness": 5.0}, "brightness must be in [0.0, 4.0], got 5.0"),
        ({"distance_per_frame": 0.0}, "distance_per_frame must be in (0.0, 10.0], got 0.0"),
        ({"attitude_jitter_deg": -1}, "attitude_jitter_deg must be in [0.0, 10.0], got -1"),
        ({"rotation_error": "x"}, "rotation_error must be a number in [0.0, 1.0], got 'x'"),
        ({"max_frames": 1}, "max_frames must be an integer >= 2 or None, got 1"),
        ({"rotation_bias": 1.0}, "rotation_bias must be in [-0.9, 0.9], got 1.0"),
        ({"translation_drift": -1}, "translation_drift must be in [0.0, 1.0], got -1"),
        ({"depth_noise": 3.0}, "depth_noise must be in [0.0, 2.0], got 3.0"),
    ],
)
def test_bad_playback_settings_name_value_and_range(kwargs, message) -> None:
    with pytest.raises(ValueError) as error:
        PlaybackSettings(**kwargs)
    assert str(error.value) == message


@pytest.mark.parametrize(
    ("size", "fov", "message"),
    [
        ((8, 36), 60.0, "width must be an integer in [16, 1280], got 8"),
        ((48, 2000), 60.0, "height must be an integer in [16, 1280], got 2000"),
        ((48, 36), 5.0, "fov_deg must be in [10.0, 150.0], got 5.0"),
    ],
)
def test_bad_world_sizes_name_value_and_range(size, fov, message) -> None:
    with pytest.raises(ValueError) as error:
        PlaybackWorld(random_path(), *size, fov_deg=fov)
    assert str(error.value) == message


def test_world_brightness_is_checked_and_frames_carry_their_grey_image() -> None:
    import cv2

    path = random_path(frames=2)
    world = PlaybackWorld(path, *SIZE)
    try:
        with pytest.raises(ValueError, match=r"^brightness must be in \[0.0, 4.0\], got -1$"):
            world.set_brightness(-1)
        frame = next(play_back(path, world, PlaybackSettings()))
    finally:
        world.close()
    np.testing.assert_array_equal(frame.gray, cv2.cvtColor(frame.image, cv2.COLOR_RGB2GRAY))


def test_bad_paths_and_files(tmp_path) -> None:
    path = random_path()
    with pytest.raises(ValueError, match=r"distance_per_frame must be in \(0, "):
        resample_by_distance(path, 100.0)
    still = path_from_poses(path.rotations(), np.zeros((len(path), 3)), 10.0)
    with pytest.raises(ValueError, match="does not move"):
        resample_by_distance(still, 0.1)
    with pytest.raises(ValueError, match="strictly increasing"):
        CameraPath([0.0, 0.0], np.zeros((2, 3)), np.tile([1.0, 0, 0, 0], (2, 1)), 10.0)
    with pytest.raises(ValueError, match="unit norm"):
        CameraPath([0.0, 0.1], np.zeros((2, 3)), np.tile([2.0, 0, 0, 0], (2, 1)), 10.0)
    with pytest.raises(FileNotFoundError):
        load_path(tmp_path / "missing.npz")
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(ValueError, match="not a flownav-camera-path file"):
        load_path(tmp_path / "other.npz")


def test_broken_path_files_are_value_errors_that_name_the_file(tmp_path) -> None:
    good = save_path(random_path(), tmp_path / "good.npz")
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(good.read_bytes()[: len(good.read_bytes()) // 2])
    with pytest.raises(ValueError, match=r"truncated.npz: not a readable flownav-camera-path file"):
        load_path(truncated)
    with np.load(good) as data:
        arrays = {key: data[key] for key in data.files if key != "positions"}
    np.savez(tmp_path / "keyless.npz", **arrays)
    with pytest.raises(ValueError, match=r"keyless.npz: missing arrays \['positions'\]"):
        load_path(tmp_path / "keyless.npz")
    with np.load(good) as data:
        arrays = {key: data[key] for key in data.files}
    arrays["obstacles"] = np.array([[np.nan, 1.0]])
    arrays["materials"] = np.array([0])
    np.savez(tmp_path / "nan.npz", **arrays)
    with pytest.raises(ValueError, match=r"nan.npz: obstacles must be finite"):
        load_path(tmp_path / "nan.npz")


def test_playback_tells_the_motion_with_bias_drift_and_noise_floor() -> None:
    path = random_path(frames=4)
    world = PlaybackWorld(path, *SIZE)
    try:
        biased = list(play_back(path, world, PlaybackSettings(rotation_bias=0.2, translation_bias=-0.5)))
        settings = PlaybackSettings(rotation_drift=0.5, translation_noise_m=0.01, seed=3)
        noisy = list(play_back(path, world, settings))
    finally:
        world.close()
    for frame in biased[1:]:
        true_vector, told_vector = (
            vector_from_rotation(m[0]) for m in (frame.true_motion, frame.told_motion)
        )
        np.testing.assert_allclose(told_vector, 1.2 * true_vector, rtol=1e-9)
        np.testing.assert_allclose(frame.told_motion[1], 0.5 * frame.true_motion[1], rtol=1e-12)
    # The drift steps at the path's frame rate, one normal per frame before the translation noise.
    replay = np.random.default_rng(3)
    walk = 0.0
    for frame in noisy[1:]:
        walk += replay.normal(0.0, 0.5 * np.sqrt(1.0 / path.frame_rate))
        angle = np.linalg.norm(vector_from_rotation(frame.told_motion[0]))
        true_angle = np.linalg.norm(vector_from_rotation(frame.true_motion[0]))
        assert angle == pytest.approx((1.0 + walk) * true_angle, rel=1e-9)
        noise = replay.normal(0.0, 0.01, 3)
        np.testing.assert_allclose(frame.told_motion[1], frame.true_motion[1] + noise, rtol=1e-12)


@pytest.mark.parametrize("name", ["depth_noise", "depth_outliers", "depth_dropout"])
def test_playback_refuses_depth_errors_it_cannot_apply(name: str) -> None:
    with pytest.raises(
        ValueError, match=rf"^{name} must be 0 in playback, got 0.1: playback runs no estimator"
    ):
        PlaybackSettings(**{name: 0.1})
    assert getattr(PlaybackSettings(**{name: 0.0}).sensor, name) == 0.0
