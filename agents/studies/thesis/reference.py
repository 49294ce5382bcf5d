"""The thesis's own figures that the report sets beside FlowNav's (Table 2's rows live in
``configs/thesis/rotation.yaml``, beside the cases that fly them)."""

from __future__ import annotations

# The thesis's focal length (Unity, 640 x 480), tuned by hand.
THESIS_FOCAL_PX = 417.0

# Table 3: per-frame seconds against the FAST threshold, random-motion flight, one capsule, an i7-4702MQ laptop.
# (test, threshold, LK error limit, fast, optical flow, depth, total, points found, points used, FPS)
TABLE3 = (
    (1, 53, 4, 0.0032, 0.0027, 0.0005, 0.006, 8.1, 4.5, 153),
    (2, 45, 4, 0.0033, 0.0033, 0.0007, 0.007, 17.1, 10.5, 140),
    (3, 40, 3, 0.0034, 0.0035, 0.0010, 0.007, 29.8, 14.8, 123),
    (4, 40, 4, 0.0034, 0.0035, 0.0013, 0.008, 29.8, 20.0, 122),
    (5, 40, 5, 0.0034, 0.0035, 0.0016, 0.008, 29.8, 23.4, 120),
    (6, 35, 4, 0.0034, 0.0040, 0.0031, 0.010, 54.2, 38.9, 95.4),
    (7, 30, 4, 0.0037, 0.0048, 0.0049, 0.013, 98.0, 75.6, 74.5),
    (8, 25, 4, 0.0039, 0.0057, 0.0064, 0.016, 144, 119, 62.4),
    (9, 20, 4, 0.0040, 0.0056, 0.0069, 0.016, 151, 128, 60.7),
    (10, 15, 4, 0.0050, 0.0067, 0.0093, 0.021, 204, 177, 47.5),
    (11, 10, 4, 0.0071, 0.0111, 0.0198, 0.038, 436, 388, 26.3),
    (12, 5, 4, 0.0110, 0.0183, 0.0385, 0.067, 830, 746, 14.8),
    (13, 4, 4, 0.0148, 0.0202, 0.0456, 0.080, 921, 842, 12.4),
    (14, 3, 4, 0.0140, 0.0228, 0.0520, 0.088, 1008, 923, 11.3),
    (15, 2, 4, 0.0146, 0.0240, 0.0557, 0.094, 1092, 997, 10.6),
    (16, 1, 4, 0.0158, 0.0247, 0.0575, 0.097, 1169, 1056, 10.2),
)


# The variable tests (three capsules; the thesis gives plots and verdicts, no numbers). Per test: our sweep
# variable, the range of its values that matches the thesis's levels, the thesis's levels and its verdict.
VARIABLE_TESTS = (
    (
        "angular instability",
        "attitude_jitter_deg",
        (0.0, 2.5),
        "0, 0.5, 1.0, 1.5, 2.0, 2.5 deg",
        "clear loss of accuracy as it grows; excessively inaccurate from 1.5 deg on; still acceptable beyond "
        "the 0.5 deg a quadcopter shows at 80 % throttle",
    ),
    (
        "larger distance per frame",
        "distance_per_frame",
        (0.05, 0.3),
        "0.05–0.30 m",
        "depths stay accurate, but far fewer successful matches as the distance grows",
    ),
    (
        "smaller distance per frame",
        "distance_per_frame",
        (0.005, 0.05),
        "0.03, 0.025, 0.02, 0.015, 0.005 m",
        "z-motion gives little useful data; x/y motion fairly accurate down to 0.02 m per frame, then spreads "
        "out; best between 0.05 and 0.15 m per frame",
    ),
    (
        "brightness",
        "brightness",
        (0.0, 1.0),
        "six levels, lowered stepwise",
        "accuracy holds for the first levels, then falls from the fourth",
    ),
    (
        "rotation input error",
        "rotation_error",
        (0.0, 0.1),
        "0–10 % (on the 0.5 deg instability run)",
        'gradual spreading; at 8 % the depths no longer give accurate information ("a strong threat")',
    ),
    (
        "rotation input error, on the attitude (our reading, see below)",
        "attitude_rotation_error",
        (0.0, 0.1),
        "–",
        "–",
    ),
    (
        "translation input error",
        "translation_error",
        (0.0, 0.1),
        "0–10 %",
        "a widening band around the true depths, close to a direct 2–10 % variation",
    ),
)
