"""Record and play back camera paths through the FlowNav scene (the thesis's record and playback modes,
§3.4–3.5): :mod:`~flownav_env.playback.path` holds the path and its file format,
:mod:`~flownav_env.playback.record` records one from an env flight, :mod:`~flownav_env.playback.world`
renders and ray-casts the scene from a placed camera, and :mod:`~flownav_env.playback.player` plays a path
back under changed test variables (brightness, distance per frame, jitter, motion errors).
"""

from flownav_env.playback.path import (
    FORMAT_NAME,
    FORMAT_VERSION,
    CameraPath,
    load_path,
    path_from_poses,
    resample_by_distance,
    save_path,
)
from flownav_env.playback.player import DISTANCE_PER_FRAME, PlaybackFrame, PlaybackSettings, play_back
from flownav_env.playback.record import record_env_flight
from flownav_env.playback.world import PlaybackWorld, label_world_points

__all__ = [
    "DISTANCE_PER_FRAME",
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "CameraPath",
    "PlaybackFrame",
    "PlaybackSettings",
    "PlaybackWorld",
    "label_world_points",
    "load_path",
    "path_from_poses",
    "play_back",
    "record_env_flight",
    "resample_by_distance",
    "save_path",
]
